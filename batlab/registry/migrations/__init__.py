"""Alembic migrations of the registry: env.py, versions/ (0001..0006), legacy helpers."""
