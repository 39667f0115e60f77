"""Small helpers shared by the commands: the registry's path and lines on stderr."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path


def add_db_argument(p: argparse.ArgumentParser) -> None:
    """Add ``--db``, the registry file, to a command's parser."""
    p.add_argument("--db", default=None,
                   help="registry: a SQLite file or a postgresql:// URL (default $BATLAB_DB, else "
                        "$XDG_DATA_HOME/batlab/registry.sqlite or "
                        "~/.local/share/batlab/registry.sqlite)")


def db_path(args: argparse.Namespace) -> Path | str:
    """Return the registry: ``--db`` if given, else the default (a file, or a server's URL).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options of a command that called ``add_db_argument``.

    Returns
    -------
    Path or str
        A PostgreSQL URL as given, else ``--db`` with ``~`` expanded, else
        ``batlab.registry.default_db_path()`` ($BATLAB_DB, else under $XDG_DATA_HOME or
        ~/.local/share).
    """
    from batlab.registry import default_db_path, is_url

    if args.db and is_url(args.db):
        return args.db
    return Path(args.db).expanduser() if args.db else default_db_path()


def progress_printer(command: str) -> Callable[[str], None]:
    """Make a ``progress(msg)`` callable printing ``batlab CMD [12.3 s]: msg`` on stderr.

    Parameters
    ----------
    command : str
        The command's name, shown in every line.

    Returns
    -------
    callable
        ``progress(message)``; the time is seconds since this call, flushed at once.
    """
    start = time.perf_counter()

    def progress(message: str) -> None:
        print(f"batlab {command} [{time.perf_counter() - start:5.1f} s]: {message}",
              file=sys.stderr, flush=True)

    return progress


def note_printer(command: str) -> Callable[[str], None]:
    """Make a ``note(msg)`` callable printing ``batlab CMD: msg`` on stderr (a default taken).

    Parameters
    ----------
    command : str
        The command's name, shown in every line.

    Returns
    -------
    callable
        ``note(message)``.
    """

    def note(message: str) -> None:
        print(f"batlab {command}: {message}", file=sys.stderr)

    return note
