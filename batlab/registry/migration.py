"""The registry's schema version and its migrations (Alembic; scripts in ``migrations/``).

Revisions are numbered ``0001``..``0007``: revision N brings a registry to schema version N.
A new registry is created at the head from ``schema.metadata`` and stamped (Alembic's
"create_all, then stamp head"); a registry made before Alembic (a ``schema_version`` table
and no ``alembic_version``) is stamped at the version it names, then upgraded. Every step runs
in one write transaction (``lock.transaction``): two processes opening an old registry at once
migrate it once, and a failed migration leaves the registry as it was.
"""

from __future__ import annotations

from pathlib import Path

import sqlalchemy as sa

from batlab.registry.lock import transaction

SCHEMA_VERSION = 7
MIGRATIONS_DIR = Path(__file__).with_name("migrations")


def revision(version: int) -> str:
    """Return the Alembic revision id of schema ``version`` (``0006`` for 6)."""
    return f"{version:04d}"


def _tables(conn: sa.Connection) -> set[str]:
    insp = sa.inspect(conn)
    return set(insp.get_table_names()) | set(insp.get_view_names())


def schema_version(conn: sa.Connection) -> int:
    """Return the database's schema version (0 for an empty database).

    Alembic's ``alembic_version`` row, else (a registry made before Alembic) the highest
    ``schema_version`` row.
    """
    tables = _tables(conn)
    if "alembic_version" in tables:
        rev = conn.exec_driver_sql("SELECT max(version_num) FROM alembic_version").scalar()
        return int(rev) if rev and rev.isdigit() else 0
    if "schema_version" in tables:
        return int(conn.exec_driver_sql("SELECT max(version) FROM schema_version").scalar()
                   or 0)
    return 0


def foreign_tables(conn: sa.Connection) -> list[str]:
    """Return the tables of a database without a batlab schema (empty for a new one)."""
    if schema_version(conn):
        return []
    return sorted(t for t in _tables(conn) if not t.startswith("sqlite_")
                  and t not in ("schema_version", "alembic_version"))


def refuse_foreign(conn: sa.Connection, where: object = "database") -> None:
    """Raise ValueError when the database holds tables of its own and no batlab schema."""
    tables = foreign_tables(conn)
    if tables:
        raise ValueError(f"{where}: not a batlab registry (it has tables of its own: "
                         f"{', '.join(tables[:5])}); left untouched")


def refuse_newer(version: int, where: object = "registry") -> None:
    """Raise ValueError when ``version`` is newer than this batlab reads."""
    if version > SCHEMA_VERSION:
        raise ValueError(f"{where}: registry schema version {version} is newer than this "
                         f"batlab ({SCHEMA_VERSION}); upgrade batlab")


def _alembic(conn: sa.Connection, version: int, target: int) -> None:
    """Run Alembic on ``conn`` (inside the caller's transaction) from ``version`` to ``target``."""
    from alembic import command
    from alembic.config import Config

    from batlab.registry.schema import metadata

    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    cfg.attributes["connection"] = conn
    if version == 0 and target == SCHEMA_VERSION:  # stamped first: its table, read on every
        command.stamp(cfg, revision(target))      # opening, is the file's first page
        metadata.create_all(conn)
        return
    if version and "alembic_version" not in _tables(conn):
        command.stamp(cfg, revision(version))
    command.upgrade(cfg, revision(target))


def migrate(conn: sa.Connection, target: int = SCHEMA_VERSION, where: object = "database",
            ) -> int:
    """Bring the database up to ``target`` in one transaction; return the version.

    The version is re-read under the write lock, so two processes opening an old database at
    once migrate it once. A database with tables of its own and no batlab schema is refused.
    """
    if not 1 <= target <= SCHEMA_VERSION:
        raise ValueError(f"unknown registry schema version {target}")
    version = schema_version(conn)
    refuse_newer(version, where)
    if version >= target:
        return version
    with transaction(conn):
        version = schema_version(conn)
        if version < target:
            if version == 0:
                refuse_foreign(conn, where)
            _alembic(conn, version, target)
    return schema_version(conn)
