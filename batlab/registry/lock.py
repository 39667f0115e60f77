"""Write transactions: one writer at a time, on SQLite and on PostgreSQL alike.

SQLite: ``BEGIN IMMEDIATE`` takes the file's write lock at the start (other writers wait up
to ``busy_timeout``). PostgreSQL: ``BEGIN`` then ``pg_advisory_xact_lock(WRITE_LOCK)``, a
transaction-level advisory lock every batlab writer takes first, so two labs appending to the
custody chain at once queue on the lock: the second reads the head the first wrote and the
chain never forks (released at ``COMMIT``/``ROLLBACK``). Readers take no lock.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

import sqlalchemy as sa

WRITE_LOCK = int.from_bytes(b"batlab-w", "big") & 0x7FFF_FFFF_FFFF_FFFF
"""The advisory lock key (a bigint) every batlab write transaction holds on PostgreSQL."""


def _begin(conn: sa.Connection) -> None:
    if conn.dialect.name == "postgresql":
        conn.exec_driver_sql("BEGIN")
        conn.exec_driver_sql(f"SELECT pg_advisory_xact_lock({WRITE_LOCK})")
    else:
        conn.exec_driver_sql("BEGIN IMMEDIATE")


def registry_name(conn: sa.Connection) -> str:
    """Return the registry an open connection is on: its file, or its URL (no password)."""
    if conn.dialect.name == "sqlite":
        try:
            rows = conn.exec_driver_sql("PRAGMA database_list").fetchall()
        except sa.exc.DBAPIError:
            return "registry"
        return next((r[2] for r in rows if r[1] == "main" and r[2]), "registry")
    return conn.engine.url.render_as_string(hide_password=True)


@contextmanager
def transaction(conn: sa.Connection) -> Iterator[sa.Connection]:
    """Run the block in one write transaction holding the registry's write lock.

    Rolled back on any exception (or never committed if the process dies). A fault that is
    not damage (busy past the wait, disk full, read-only, permission: ``faults.fault_text``)
    is a one-line ValueError naming the registry; nothing was stored.
    """
    started = time.monotonic()
    try:
        _begin(conn)
        try:
            yield conn
        except BaseException:
            try:
                conn.exec_driver_sql("ROLLBACK")
            except sa.exc.DBAPIError:  # SQLite rolled back itself (disk full, I/O error)
                pass
            raise
        conn.exec_driver_sql("COMMIT")
    except sa.exc.DBAPIError as exc:
        from batlab.registry.faults import fault_text

        text = fault_text(registry_name(conn), exc, time.monotonic() - started)
        if text is not None:
            raise ValueError(text) from None
        raise


@contextmanager
def snapshot(conn: sa.Connection) -> Iterator[sa.Connection]:
    """Read in the block from one consistent snapshot, taking no write lock.

    SQLite: a deferred ``BEGIN`` (in WAL mode its first read fixes the snapshot).
    PostgreSQL: ``BEGIN ISOLATION LEVEL REPEATABLE READ, READ ONLY``. Always rolled back.
    """
    pg = conn.dialect.name == "postgresql"
    conn.exec_driver_sql("BEGIN ISOLATION LEVEL REPEATABLE READ, READ ONLY" if pg else "BEGIN")
    try:
        yield conn
    finally:
        conn.exec_driver_sql("ROLLBACK")
