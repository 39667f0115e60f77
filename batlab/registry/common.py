"""Where the registry is, and the small values every part of it uses: hashes, time stamps."""

from __future__ import annotations

import hashlib
import os
from datetime import datetime, timezone
from pathlib import Path

BUSY_TIMEOUT_S = 60.0
URL_SCHEMES = ("postgresql://", "postgresql+psycopg://", "postgres://")


def is_url(db: str | os.PathLike) -> bool:
    """Return whether ``db`` names a PostgreSQL server (a URL) rather than a SQLite file."""
    return isinstance(db, str) and db.startswith(URL_SCHEMES)


def shown(db: str | os.PathLike) -> str:
    """Return ``db`` as messages show it: a file's path, or a URL without its password."""
    if not is_url(db):
        return str(db)
    scheme, _, rest = str(db).partition("://")
    who, at, where = rest.rpartition("@")
    return f"{scheme}://{who.split(':', 1)[0]}{at}{where}" if at else str(db)


def default_db_path(env: dict | None = None) -> Path | str:
    """Return the registry: a SQLite file's path, or a PostgreSQL URL kept as text.

    ``$BATLAB_DB``, else ``$XDG_DATA_HOME/batlab/registry.sqlite``, else
    ``~/.local/share/batlab/registry.sqlite``.
    """
    env = os.environ if env is None else env
    if env.get("BATLAB_DB"):
        return env["BATLAB_DB"] if is_url(env["BATLAB_DB"]) else \
            Path(env["BATLAB_DB"]).expanduser()
    base = env.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base).expanduser() / "batlab" / "registry.sqlite"


def sha256_bytes(data: bytes) -> str:
    """Return the hex SHA-256 of ``data``."""
    return hashlib.sha256(data).hexdigest()


def now_utc() -> str:
    """Return an ISO 8601 UTC time stamp with microseconds (sorts as text)."""
    return datetime.now(timezone.utc).isoformat(timespec="microseconds")
