"""Small helpers shared by the registry commands: the database path and progress lines."""

from __future__ import annotations

import sys
import time
from pathlib import Path


def add_db_argument(p) -> None:
    p.add_argument("--db", default=None,
                   help="registry file (default $BATLAB_DB, else "
                        "$XDG_DATA_HOME/batlab/registry.sqlite or "
                        "~/.local/share/batlab/registry.sqlite)")


def db_path(args) -> Path:
    from batlab.registry import default_db_path

    return Path(args.db).expanduser() if args.db else default_db_path()


def progress_printer(command: str):
    """A ``progress(msg)`` callable printing ``batlab CMD [12.3 s]: msg`` on stderr."""
    start = time.perf_counter()

    def progress(message: str) -> None:
        print(f"batlab {command} [{time.perf_counter() - start:5.1f} s]: {message}",
              file=sys.stderr, flush=True)

    return progress


def note_printer(command: str):
    """A ``note(msg)`` callable printing ``batlab CMD: msg`` on stderr (a default taken)."""

    def note(message: str) -> None:
        print(f"batlab {command}: {message}", file=sys.stderr)

    return note
