"""A database error on the registry, named: busy, disk full, read-only, permission, damaged.

SQLite answers every failure with an error code (``sqlite3.Error.sqlite_errorcode``; the
primary code is its low byte), PostgreSQL with an SQLSTATE. ``fault_text`` turns the codes
that are not damage into one line saying what happened and what to do: another process holds
the write lock past the wait (``SQLITE_BUSY``/``SQLITE_LOCKED``, SQLSTATE 55P03/40P01: who
holds it, how long batlab waited), the disk is full (``SQLITE_FULL``, 53100), the file or its
directory cannot be written (``SQLITE_READONLY``: a read-only mount or file), the file cannot
be opened (``SQLITE_CANTOPEN``, ``SQLITE_PERM``, 42501), an I/O error (``SQLITE_IOERR``).
Whatever else it is, it is called damaged only when the database's own storage check
(``health.storage_problems``) finds damage (``describe``): a locked or full registry is not a
damaged one.
"""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path

import sqlalchemy as sa

from batlab.registry.common import shown
from batlab.registry.health import damage_text, storage_problems

_BUSY = {sqlite3.SQLITE_BUSY, sqlite3.SQLITE_LOCKED}
_SERVER_BUSY = {"55P03", "40P01", "57014"}  # lock not available, deadlock, statement timeout


def _orig(exc: BaseException) -> BaseException:
    return getattr(exc, "orig", None) or exc


def _one_line(exc: BaseException) -> str:
    return " ".join(str(_orig(exc)).split())


def holders(path: str | os.PathLike) -> list[str]:
    """Return the other processes that have the registry file open (Linux ``/proc``).

    Each as ``pid N (its command line)``; empty where ``/proc`` cannot say (another OS, or
    another user's processes this one may not look at). One of them holds the write lock.
    """
    try:
        target = Path(path).resolve()
        names = {str(target), f"{target}-wal", f"{target}-shm"}
        procs = [p for p in Path("/proc").iterdir() if p.name.isdigit()]
    except OSError:
        return []
    found = []
    for proc in procs:
        if int(proc.name) == os.getpid():
            continue
        try:
            if not any(os.readlink(fd) in names for fd in (proc / "fd").iterdir()):
                continue
            argv = (proc / "cmdline").read_bytes().split(b"\0")
            command = " ".join(" ".join(a.decode(errors="replace") for a in argv).split())
            command = command[:77] + "..." if len(command) > 80 else command
        except OSError:  # gone meanwhile, or not ours to look at
            continue
        found.append(f"pid {proc.name} ({command})")
    return found


def fault_text(db: object, exc: BaseException, waited_s: float | None = None) -> str | None:
    """Return one line naming a fault that is not damage (None when it may be damage).

    Parameters
    ----------
    db : str or path
        The registry, as messages show it.
    exc : BaseException
        The driver's error (``sqlite3.Error``, ``psycopg.Error``) or SQLAlchemy's wrapper.
    waited_s : float or None
        How long batlab waited for the write lock before the error, s.

    Returns
    -------
    str or None
        ``DB: registry busy: ...``, ``DB: disk full ...``, ``DB: registry is read-only
        ...``, ``DB: permission denied ...``, ``DB: I/O error ...``; None for anything else.
    """
    orig, reason, where = _orig(exc), _one_line(exc), shown(db)
    code = getattr(orig, "sqlite_errorcode", None)
    primary = None if code is None else code & 0xFF
    state = getattr(orig, "sqlstate", None)
    if primary in _BUSY or state in _SERVER_BUSY:
        who = holders(db) if primary is not None else []
        held = f"held by {', '.join(who[:3])}" if who else "held by another process"
        waited = "" if waited_s is None else f"; batlab waited {waited_s:.0f} s for it"
        return (f"{where}: registry busy: its write lock is {held}{waited} ({reason}); "
                "nothing was stored: run the command again when that process is done")
    if primary == sqlite3.SQLITE_FULL or state == "53100":
        return (f"{where}: disk full ({reason}): nothing was stored, the registry is as it "
                "was; free space on its disk and run the command again")
    if primary == sqlite3.SQLITE_READONLY or state == "25006":
        return (f"{where}: registry is read-only ({reason}): nothing can be stored in it "
                "(a read-only file or mount; reading it works)")
    if primary in (sqlite3.SQLITE_CANTOPEN, sqlite3.SQLITE_PERM) or state == "42501":
        return (f"{where}: permission denied ({reason}): this user may not open or write the "
                "registry or its directory (SQLite writes -wal and -shm files beside it)")
    if primary == sqlite3.SQLITE_IOERR:
        return (f"{where}: I/O error on the registry's disk ({reason}): nothing was stored; "
                "check the disk, then `batlab registry check` the registry")
    return None


def describe(db: object, exc: BaseException) -> str:
    """Return one line for any database error on the registry ``db`` (a file or a URL).

    ``fault_text``'s words when it names the fault; else the storage check is run on a
    fresh read-only opening: ``registry damaged (...)`` only when it finds damage, else
    ``registry error (...)``, saying the check found none.
    """
    text = fault_text(db, exc)
    if text is not None:
        return text
    reason, where = _one_line(exc), shown(db)
    problems = _storage_check(db)
    if problems:
        return (f"{damage_text(db, problems)}; the error: {reason}; `batlab registry check "
                f"--db {where}` says where")
    said = "finds no damage" if problems == [] else "could not run"
    return f"{where}: registry error ({reason}); its storage check {said}"


def _storage_check(db: object) -> list[str] | None:
    """Run the storage check on a fresh read-only opening (None if it cannot be opened)."""
    from batlab.registry.common import is_url

    if db is None or is_url(db):
        return None  # a server's error is its own message: not checked from here
    path = Path(db)
    try:
        raw = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
    except sqlite3.Error:
        return None
    engine = sa.create_engine("sqlite://", creator=lambda: raw)
    try:
        with engine.connect() as conn:
            return storage_problems(conn)
    except sqlite3.DatabaseError as exc:  # not a database at all
        return [_one_line(exc)]
    finally:
        engine.dispose()
