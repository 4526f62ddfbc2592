"""Closed-loop simulation support: exact collision check, the versioned run log, and run plots."""
