"""Alembic migrations of the registry: env.py, versions/ (0001..0005), legacy helpers."""
