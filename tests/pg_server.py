"""A throw-away PostgreSQL 15 server for the tests, on a Unix socket in a temporary folder.

Debian's server binaries live in /usr/lib/postgresql/15/bin (not on PATH) and ``initdb``
refuses to run as root, so as root the server runs as the ``postgres`` system user
(``runuser -u postgres --``) in a folder handed to it; it listens on no TCP port
(``listen_addresses=''``), only on a socket in that folder.
"""

from __future__ import annotations

import os
import pwd
import shutil
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

PG_BIN = Path(os.environ.get("BATLAB_PG_BIN", "/usr/lib/postgresql/15/bin"))
PG_USER = "postgres"


def missing_reason() -> str | None:
    """Return why no server can be started here (None when one can)."""
    if not (PG_BIN / "initdb").exists():
        return f"PostgreSQL server binaries not found in {PG_BIN}"
    if os.geteuid() == 0:
        try:
            pwd.getpwnam(PG_USER)
        except KeyError:
            return f"running as root and there is no {PG_USER!r} user to run the server"
    return None


def _as_server_user(argv: list[str]) -> list[str]:
    """Run ``argv`` as the ``postgres`` user when we are root (initdb refuses root)."""
    return ["runuser", "-u", PG_USER, "--", *argv] if os.geteuid() == 0 else argv


@contextmanager
def pg_server(folder: Path, database: str = "batlab") -> Iterator[str]:
    """Start a server in ``folder``, create ``database``, yield its URL, stop the server.

    Parameters
    ----------
    folder : Path
        An empty folder for the cluster (``data/``), its socket and its log; as root, one
        the ``postgres`` user can reach (e.g. ``tempfile.mkdtemp()`` under /tmp).
    database : str
        Name of the database to create.

    Yields
    ------
    str
        ``postgresql://postgres@/DATABASE?host=FOLDER``.
    """
    folder.mkdir(parents=True, exist_ok=True)
    if os.geteuid() == 0:  # the folder's parents must let the server user through
        entry = pwd.getpwnam(PG_USER)
        shutil.chown(folder, entry.pw_uid, entry.pw_gid)
    data = folder / "data"
    run = dict(check=True, capture_output=True, text=True)
    subprocess.run(_as_server_user([str(PG_BIN / "initdb"), "-D", str(data), "-U", PG_USER,
                                    "-A", "trust", "--no-sync"]), **run)
    _pg_ctl(folder, "start")
    try:
        subprocess.run(_as_server_user([str(PG_BIN / "createdb"), "-h", str(folder), "-U",
                                        PG_USER, database]), **run)
        yield f"postgresql://{PG_USER}@/{database}?host={folder}"
    finally:
        subprocess.run(_as_server_user([str(PG_BIN / "pg_ctl"), "-D", str(data), "-m", "fast",
                                        "-w", "stop"]), capture_output=True)


def _pg_ctl(folder: Path, action: str) -> None:
    """``pg_ctl start`` or ``stop`` the server of ``folder`` (its socket there, no TCP)."""
    opts = (f"-c listen_addresses='' -c unix_socket_directories={folder} -c fsync=off "
            "-c max_connections=40")
    how = ["-l", str(folder / "server.log"), "-o", opts] if action == "start" else \
        ["-m", "fast"]
    subprocess.run(_as_server_user([str(PG_BIN / "pg_ctl"), "-D", str(folder / "data"), *how,
                                    "-w", action]), check=True, capture_output=True, text=True)


@contextmanager
def server_stopped(url: str) -> Iterator[Path]:
    """Stop the server of ``url`` for the block (yielding its data folder), start it after."""
    folder = Path(dict(p.split("=", 1) for p in url.partition("?")[2].split("&"))["host"])
    _pg_ctl(folder, "stop")
    try:
        yield folder / "data"
    finally:
        _pg_ctl(folder, "start")


def create_database(url: str, name: str) -> str:
    """Create database ``name`` on the server of ``url``; return its URL (same socket)."""
    base, _, query = url.partition("?")
    host = dict(p.split("=", 1) for p in query.split("&"))["host"]
    subprocess.run(_as_server_user([str(PG_BIN / "createdb"), "-h", host, "-U", PG_USER, name]),
                   check=True, capture_output=True, text=True)
    return f"{base.rsplit('/', 1)[0]}/{name}?{query}"
