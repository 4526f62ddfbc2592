"""fcgen: generate static-memory embedded C NMPC solvers for Frenet-Cartesian obstacle avoidance, and prove them."""

__version__ = "0.20.0"
"""The one version: pyproject.toml reads it (setuptools dynamic), the generated files and `fcgen --version` show it."""
