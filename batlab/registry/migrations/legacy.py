"""Helpers of the migrations written before Alembic (schemas 1-4, SQLite files only)."""

from __future__ import annotations

import sqlalchemy as sa


def script(conn: sa.Connection, sql: str) -> None:
    """Run ``;``-separated statements inside the current transaction."""
    for stmt in sql.split(";"):
        if stmt.strip():
            conn.exec_driver_sql(stmt)
