"""The database's own check of the registry's storage: run at every opening, before any write.

SQLite: ``PRAGMA quick_check`` walks every page of every table and index and the free-page
list and checks each page's form and its cells (O(pages); what it leaves out of ``PRAGMA
integrity_check``, which ``registry check`` runs, is the cross-check of each index against
its table and of UNIQUE constraints). Bytes that still read as valid values (a changed
verdict, a stored file's content) are not its to see: the custody chain and the files'
SHA-256 are (``registry check``). PostgreSQL: every table batlab keeps read through (every
heap page's header checked as the server reads it, and its checksum where the cluster keeps
them); where the ``amcheck`` extension is installed and this user may run it, its
``verify_heapam`` (TOAST included, where the stored files' bytes live) and
``bt_index_check`` on those tables and their B-tree indexes too.

A damaged registry is refused before anything is written into it, and a read warns
(``batlab.registry.engine``; docs/registry.md).
"""

from __future__ import annotations

import sqlite3

import sqlalchemy as sa

from batlab.registry.common import shown
from batlab.registry.schema import metadata

SHOWN_ROWS = 2
"""How many lines of the database's answer a message quotes."""


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def storage_problems(conn: sa.Connection, thorough: bool = False) -> list[str]:
    """Return what the database's own check finds wrong with the registry's storage.

    Parameters
    ----------
    conn : sqlalchemy.Connection
        An open registry (SQLite or PostgreSQL), outside any transaction.
    thorough : bool
        SQLite: ``integrity_check`` (indexes checked against their tables) instead of
        ``quick_check``.

    Returns
    -------
    list of str
        Empty when the check passes, else its complaints, one line each (a check that could
        not run at all is one complaint: the driver's message). A file that is not a
        database at all raises its ``sqlite3.DatabaseError`` (SQLITE_NOTADB) as the opening
        would.
    """
    if conn.dialect.name == "sqlite":
        return _sqlite_problems(conn, "integrity_check" if thorough else "quick_check")
    return _server_problems(conn)


def _sqlite_problems(conn: sa.Connection, pragma: str) -> list[str]:
    try:
        rows = [bytes(r[0]).decode(errors="replace") for r in conn.exec_driver_sql(
            f"SELECT CAST({pragma} AS BLOB) FROM pragma_{pragma}").fetchall()]  # may quote junk
    except (sa.exc.DBAPIError, sqlite3.DatabaseError, UnicodeDecodeError) as exc:
        orig = getattr(exc, "orig", None) or exc  # (a garbled schema's text is not UTF-8)
        if getattr(orig, "sqlite_errorcode", None) == sqlite3.SQLITE_NOTADB:
            raise orig from None  # not a database: the opening's own message says so
        return [_one_line(orig)]
    if rows == ["ok"]:
        return []
    lines = [line for r in rows for line in r.splitlines() if line.strip()]
    return [_one_line(line) for line in lines
            if not line.startswith("*** in database")] or [_one_line(" ".join(rows))]


def _server_problems(conn: sa.Connection) -> list[str]:
    """Read every batlab table's heap through; amcheck's checks where this user may run them.

    ``count(ctid)`` needs every row's place in the heap, so the heap's pages are read (an
    index alone cannot answer it). Runs inside the caller's transaction if there is one.
    """
    present = set(sa.inspect(conn).get_table_names()) & {*metadata.tables, "alembic_version"}
    usable = set(conn.exec_driver_sql(
        "SELECT proname FROM pg_proc WHERE proname IN ('verify_heapam', 'bt_index_check') "
        "AND has_function_privilege(oid, 'EXECUTE')").scalars())
    try:
        for table in sorted(present):
            conn.exec_driver_sql(f"SELECT count(ctid) FROM {table}").scalar()
            if "verify_heapam" in usable:  # its TOAST table (the files' bytes) too
                bad = conn.exec_driver_sql(
                    f"SELECT msg FROM verify_heapam('{table}') LIMIT {SHOWN_ROWS}").scalars()
                problems = [f"table {table}: {_one_line(m)}" for m in bad]
                if problems:
                    return problems
            if "bt_index_check" in usable:
                conn.exec_driver_sql(
                    "SELECT bt_index_check(i.indexrelid) FROM pg_index i JOIN pg_class c ON "
                    "c.oid = i.indexrelid JOIN pg_am a ON a.oid = c.relam WHERE a.amname = "
                    f"'btree' AND i.indrelid = '{table}'::regclass").all()
    except sa.exc.DBAPIError as exc:
        return [_one_line(str(exc.orig).splitlines()[0])]
    return []


def damage_text(db: object, problems: list[str]) -> str:
    """Return ``DB: registry damaged (its first complaints; N more)`` on one line."""
    more = len(problems) - SHOWN_ROWS
    said = "; ".join(problems[:SHOWN_ROWS]) + (f"; {more} more" if more > 0 else "")
    return f"{shown(db)}: registry damaged ({said})"
