"""fcgen: generate static-memory embedded C NMPC solvers for Frenet-Cartesian obstacle avoidance, and prove them."""

__version__ = "0.1.0"
