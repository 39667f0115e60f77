"""Opening the registry: a SQLite file (the default) or a PostgreSQL server named by a URL.

Either way the result is a SQLAlchemy ``Connection`` in autocommit mode: reads take no lock
and every write opens its own ``lock.transaction``. SQLite: WAL journal, ``busy_timeout``,
``synchronous = FULL``, foreign keys on, and a read-only opening that leaves no file behind.
PostgreSQL: psycopg 3 (``postgresql+psycopg://``), one connection per opening; ``readonly``
sets ``default_transaction_read_only``.

Every opening runs the database's own storage check (``health.storage_problems``: SQLite's
``quick_check``) before anything can be written: a damaged registry opened for writing (or
needing a migration) is refused, nothing written into it; opened for reading, it is read and
``warn`` says it is damaged.
"""

from __future__ import annotations

import os
import sqlite3
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import sqlalchemy as sa
from sqlalchemy.pool import NullPool

from batlab.registry.common import BUSY_TIMEOUT_S, is_url, shown
from batlab.registry.faults import fault_text
from batlab.registry.health import damage_text, storage_problems
from batlab.registry.migration import (
    SCHEMA_VERSION,
    migrate,
    refuse_foreign,
    refuse_newer,
    schema_version,
)

_UNREADABLE = (sqlite3.DatabaseError, sa.exc.DBAPIError, UnicodeDecodeError)
"""What reading a damaged file raises (a garbled schema's text is not UTF-8)."""


def _wrap(raw: sqlite3.Connection) -> sa.Connection:
    """Return an autocommit SQLAlchemy connection over an open sqlite3 connection."""
    engine = sa.create_engine("sqlite://", creator=lambda: raw, poolclass=NullPool)
    return engine.connect().execution_options(isolation_level="AUTOCOMMIT")


def _reason(exc: Exception) -> str:
    """Return the driver's own message of a database error, on one line."""
    orig = getattr(exc, "orig", None) or exc
    return " ".join(str(orig).split())


def _writable(path: Path) -> bool:
    """Return whether this process can write the file and its directory (WAL needs both)."""
    return os.access(path, os.W_OK) and os.access(path.parent, os.W_OK)


def _enable_wal(conn: sqlite3.Connection, deadline_s: float = BUSY_TIMEOUT_S) -> None:
    """Run ``PRAGMA journal_mode = WAL``, retried while another process holds the file.

    Switching a file to WAL upgrades a shared lock to an exclusive one; while another
    connection holds the reserved lock (a second process creating the same registry) that
    upgrade could deadlock, so SQLite answers "database is locked" at once, without its busy
    handler (1 run in 30 of four processes creating one registry under load). The mode is
    stored in the file, so the retry usually finds it already set.
    """
    stop = time.monotonic() + deadline_s
    pause_s = 0.005
    while True:
        try:
            conn.execute("PRAGMA journal_mode = WAL")
            return
        except sqlite3.OperationalError as exc:
            if "locked" not in str(exc) or time.monotonic() > stop:
                raise
        time.sleep(pause_s)
        pause_s = min(2 * pause_s, 0.2)


def connect(
    db: str | os.PathLike, target: int = SCHEMA_VERSION, create: bool = True,
    readonly: bool = False, warn: Callable[[str], None] | None = None,
) -> sa.Connection:
    """Open the registry ``db`` (creating it if ``create``) and migrate it to ``target``.

    Parameters
    ----------
    db : str or path
        A SQLite file, or a PostgreSQL URL (``postgresql://user@host/db``, also
        ``postgresql:///db?host=/socket/dir``).
    target : int
        Schema version to bring it to (the newest by default).
    create : bool
        Create the registry (file or tables) when there is none.
    readonly : bool
        Open it read-only: nothing is written (an older schema is migrated only when it can
        be written, else refused with a message saying what to do).
    warn : callable or None
        Receives the one-line warning when a registry opened for reading fails the storage
        check (``health.storage_problems``); None: read without a word.

    Returns
    -------
    sqlalchemy.Connection
        In autocommit mode; close it when done (``open_registry`` does).

    Raises
    ------
    ValueError
        One line naming the registry: missing, unreadable, not a registry, newer schema,
        damaged (when opened for writing, or to migrate).
    """
    if is_url(db):
        return _connect_server(str(db), target, create, readonly, warn)
    return _connect_file(Path(db), target, create, readonly, warn)


def _judge_storage(conn: sa.Connection, db: object, writing: bool,
                   warn: Callable[[str], None] | None) -> None:
    """Run the storage check on a fresh opening, before its first write.

    Damaged and ``writing``: ValueError in one line naming the registry and ``batlab registry
    check``, the connection closed. Damaged and read: ``warn`` gets one line (a read with no
    ``warn`` is not checked).
    """
    if not writing and warn is None:
        return
    problems = storage_problems(conn)
    if not problems:
        return
    text = damage_text(db, problems)
    check = f"`batlab registry check --db {shown(db)}`"
    if writing:
        conn.close()
        raise ValueError(f"{text}: refused, nothing written into it; {check} says where")
    warn(f"warning: {text}: what is read from it may be wrong or missing; {check} says where")


def _driver_url(url: str) -> str:
    """Return ``url`` with psycopg 3 named as the driver."""
    scheme, _, rest = url.partition("://")
    return url if "+" in scheme else f"postgresql+psycopg://{rest}"


def _connect_server(url: str, target: int, create: bool, readonly: bool,
                    warn: Callable[[str], None] | None) -> sa.Connection:
    """Open a PostgreSQL registry; ValueError naming the URL (no password) on failure."""
    try:
        engine = sa.create_engine(_driver_url(url), poolclass=NullPool)
        conn = engine.connect().execution_options(isolation_level="AUTOCOMMIT")
    except (sa.exc.DBAPIError, sa.exc.ArgumentError) as exc:
        raise ValueError(f"{shown(url)}: cannot open the PostgreSQL registry "
                         f"({_reason(exc)})") from None
    try:
        version = schema_version(conn)
        if version == 0 and not create:
            raise ValueError(f"{shown(url)}: no registry there (register a bat first, or "
                             "give --db)")
        writing = version < target or not readonly
        _judge_storage(conn, url, writing, warn)
        if writing:
            migrate(conn, target, shown(url))
        refuse_newer(version, shown(url))
        if readonly:
            conn.exec_driver_sql("SET default_transaction_read_only = on")
    except BaseException:
        conn.close()
        raise
    return conn


def _connect_file(path: Path, target: int, create: bool, readonly: bool,
                  warn: Callable[[str], None] | None) -> sa.Connection:
    """Open a SQLite registry file; every failure is a ValueError naming the file."""
    if path.exists() and path.is_dir():
        raise ValueError(f"{path}: registry path is a directory")
    if not create and not path.exists():
        raise ValueError(f"{path}: no registry there (register a bat first, or give --db)")
    if path.exists() and not os.access(path, os.R_OK):
        raise ValueError(f"{path}: registry not readable (permission denied)")
    if path.exists() and path.stat().st_size:
        _refuse_foreign_file(path)
    if readonly or (path.exists() and not _writable(path)):
        conn = _connect_readonly(path, migratable=_writable(path))
        if conn is not None:
            _judge_storage(conn, path, not readonly, warn)
            return conn
    elif not create and path.exists() and _holds_no_registry(path):  # looked at read-only
        raise ValueError(_empty_text(path))  # a command that must not make one: the file as is
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{path}: cannot create the registry's directory ({exc.strerror})") \
            from None
    conn = None
    try:
        raw = sqlite3.connect(path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        raw.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
        conn = _wrap(raw)
        _judge_storage(conn, path, True, warn)  # before the first write (WAL, migration)
        _enable_wal(raw)
        raw.execute("PRAGMA synchronous = FULL")
        raw.execute("PRAGMA foreign_keys = ON")
        migrate(conn, target, path)
    except _UNREADABLE as exc:
        if conn is not None:
            conn.close()
        raise ValueError(fault_text(path, exc) or
                         f"{path}: not a usable batlab registry ({_reason(exc)})") from None
    except BaseException:
        if conn is not None:
            conn.close()
        raise
    return conn


def _refuse_foreign_file(path: Path) -> None:
    """Look at an existing file without changing it.

    ValueError if it holds tables of its own and no batlab schema. A file SQLite cannot read
    here (not a database, or one being created by another process) is left to the normal opening
    to judge.
    """
    try:
        probe = _wrap(sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro&immutable=1",
                                      uri=True))
    except _UNREADABLE:
        return
    try:
        refuse_foreign(probe, path)
    except _UNREADABLE:
        return
    finally:
        probe.close()


class _ReadOnlyConnection(sqlite3.Connection):
    """A read-only connection that removes the ``-wal``/``-shm`` files its opening created.

    Left behind, they are this user's and lock the owner out.
    """

    created: tuple[Path, ...] = ()

    def close(self) -> None:
        super().close()
        for leftover in self.created:
            try:  # (on a read-only mount even unlinking a missing file fails: EROFS)
                if leftover.exists() and (leftover.name.endswith("-shm")
                                          or leftover.stat().st_size == 0):
                    leftover.unlink()
            except OSError:
                pass  # cannot be removed from here: left as it is


class _NoRegistry(ValueError):
    """A file that holds no registry (schema 0), refused as such."""


def _empty_text(path: Path) -> str:
    """Return the one line refusing a registry file that holds no registry."""
    size = path.stat().st_size
    return (f"{path}: holds no registry yet (an empty {'0-byte ' if size == 0 else ''}file: "
            "a first `batlab register` stopped before it stored anything leaves one); "
            "register a bat into it first, or give another --db")


def _holds_no_registry(path: Path) -> bool:
    """Return whether the file holds no registry (schema 0), looked at read-only.

    A file that cannot be read so is left to the opening to judge (False).
    """
    try:
        probe = _connect_readonly(path)
    except _NoRegistry:
        return True
    except ValueError:
        return False
    probe.close()
    return False


def _connect_readonly(path: Path, migratable: bool = False) -> sa.Connection | None:
    """Open a read-only connection that leaves nothing behind and never reads stale data.

    With no write-ahead log content the file is opened ``immutable=1`` (no ``-shm`` needed,
    none created); with WAL content ``mode=ro`` reads it through the ``-shm`` index and the
    files that created are removed on close; where that index cannot be made the registry is
    refused rather than read without its log. A file holding no registry (schema 0: empty,
    as a first ``register`` killed before its commit leaves it) is refused, left as it is.
    Returns None for an older schema when
    ``migratable`` (the caller then opens it for writing and migrates it).
    """
    wal, shm = Path(f"{path}-wal"), Path(f"{path}-shm")
    before = {p for p in (wal, shm) if p.exists()}
    live_log = wal.exists() and wal.stat().st_size > 0
    flags = "mode=ro" if live_log else "mode=ro&immutable=1"
    try:
        raw = sqlite3.connect(f"{path.resolve().as_uri()}?{flags}", uri=True,
                              timeout=BUSY_TIMEOUT_S, isolation_level=None,
                              factory=_ReadOnlyConnection)
        raw.created = tuple(p for p in (wal, shm) if p not in before)
        conn = _wrap(raw)
        version = schema_version(conn)
    except _UNREADABLE as exc:
        if live_log:
            raise ValueError(f"{path}: its write-ahead log {wal.name} cannot be read here "
                             f"without its index ({_reason(exc)}); open the registry once with "
                             "write access (reading the file alone would show stale data)") \
                from None
        raise ValueError(f"{path}: not a usable batlab registry ({_reason(exc)})") from None
    if version == SCHEMA_VERSION:
        return conn
    conn.close()
    if version == 0:
        raise _NoRegistry(_empty_text(path))
    if 0 < version < SCHEMA_VERSION and migratable:
        return None
    refuse_newer(version, path)
    raise ValueError(f"{path}: read-only registry at schema version {version}, this batlab "
                     f"reads {SCHEMA_VERSION} (open it once with write access to migrate)")


@contextmanager
def open_registry(
    db: str | os.PathLike, create: bool = True, readonly: bool = False,
    warn: Callable[[str], None] | None = None,
) -> Iterator[sa.Connection]:
    """Open the registry with ``connect`` for the block, and close it after.

    A database error inside the block reaches the caller as the driver's own error for a
    SQLite file (``sqlite3.DatabaseError``: damage found after opening) and as a one-line
    ValueError naming the server for PostgreSQL.
    """
    conn = connect(db, create=create, readonly=readonly, warn=warn)
    try:
        yield conn
    except sa.exc.DBAPIError as exc:
        if isinstance(exc.orig, sqlite3.DatabaseError):
            raise exc.orig from None
        raise ValueError(f"{shown(db)}: registry error ({_reason(exc)})") from None
    finally:
        conn.close()
