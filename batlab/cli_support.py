"""Small helpers shared by the commands: the registry's path and lines on stderr."""

from __future__ import annotations

import argparse
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

from updating.inspect.parallel import QUIET_THREAD_PREFIX


def say(text: object = "", file=None) -> None:
    """Print a line for a person: its control and format characters escaped.

    Serials, species, file names and notes come from lab files and registries; an escape
    sequence, a NUL or a right-to-left override among them must not reach the terminal
    (``batlab.safe_text.for_terminal``). ``--json`` output is ``json.dumps``' (escaped).
    """
    from batlab.safe_text import for_terminal

    print(for_terminal(text, keep="\n\t"), file=file or sys.stdout, flush=file is sys.stderr)


def stdout_closed() -> None:
    """Point stdout at /dev/null once its reader is gone (``batlab ... | head``).

    Nothing printed after, nor Python's final flush, then raises ``BrokenPipeError``.
    """
    import os

    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # no real stdout (a test's capture): nothing to redirect
        pass
    finally:
        os.close(devnull)


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

    Raises
    ------
    ValueError
        ``--db`` (or $BATLAB_DB) is a URL of another kind of server (``mysql://...``).
    """
    import os

    from batlab.registry import default_db_path, is_url

    for label, given in (("--db", args.db), ("$BATLAB_DB", os.environ.get("BATLAB_DB"))):
        if given:
            if "://" in given and not is_url(given):
                scheme = given.split("://", 1)[0]
                raise ValueError(f"{label} {scheme}://...: not a registry batlab opens (give a "
                                 "SQLite file's path or a postgresql:// URL)")
            break
    if args.db and is_url(args.db):
        return args.db
    return Path(args.db).expanduser() if args.db else default_db_path()


def read_registry(args: argparse.Namespace, command: str):
    """Open the registry of ``--db`` read-only for a block (it must exist).

    A registry that fails the storage check (``batlab.registry.health``) is read, with one
    warning line on stderr (``batlab COMMAND: warning: ...``).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options of a command that called ``add_db_argument``.
    command : str
        The command's name, shown in the warning.

    Returns
    -------
    contextmanager
        ``batlab.registry.open_registry(..., create=False, readonly=True)``.
    """
    from batlab.registry import open_registry

    return open_registry(db_path(args), create=False, readonly=True,
                         warn=note_printer(command))


HEARTBEAT_S = 5.0
"""A step running this long without a new line gets a 'still ...' line on stderr."""
_RUNNING: list[Progress] = []


class Progress:
    """``progress(msg)``: print ``batlab CMD [12.3 s]: msg`` on stderr, and keep saying it.

    While one step runs longer than ``HEARTBEAT_S`` without a new message, a background
    thread prints ``still <step> (10 s on this step)`` every ``HEARTBEAT_S``, so no long work
    is silent. The thread only sleeps and prints, so it is named as one a fit may fork
    beside (``updating.inspect.parallel.QUIET_THREAD_PREFIX``). ``stop_all``
    (``batlab.cli.main``, at the command's end) ends the threads.

    Parameters
    ----------
    command : str
        The command's name, shown in every line.
    every_s : float
        The heartbeat's period, s.
    """

    def __init__(self, command: str, every_s: float = HEARTBEAT_S):
        self.command, self.every_s = command, every_s
        self.start = self._since = time.perf_counter()
        self._step: str | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def __call__(self, message: str) -> None:
        """Print one step's line (the time is seconds since the command started)."""
        with self._lock:
            self._step, self._since = message, time.perf_counter()
            if self._thread is None:
                self._thread = threading.Thread(target=self._beat, daemon=True,
                                                name=f"{QUIET_THREAD_PREFIX}heartbeat")
                self._thread.start()
                _RUNNING.append(self)
        self._print(message)

    def _print(self, message: str) -> None:
        say(f"batlab {self.command} [{time.perf_counter() - self.start:5.1f} s]: {message}",
            file=sys.stderr)

    def _beat(self) -> None:
        while not self._stop.wait(self.every_s):
            with self._lock:
                step, took = self._step, time.perf_counter() - self._since
            if step is not None and took >= self.every_s:
                self._print(f"still {step.rstrip(' .')} ({took:.0f} s on this step)")

    def stop(self) -> None:
        """End the heartbeat (idempotent)."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join()


def stop_all() -> None:
    """Stop every running ``Progress``'s heartbeat (the command is done)."""
    while _RUNNING:
        _RUNNING.pop().stop()


def progress_printer(command: str) -> Progress:
    """Make a ``progress(msg)`` callable printing ``batlab CMD [12.3 s]: msg`` on stderr.

    Parameters
    ----------
    command : str
        The command's name, shown in every line.

    Returns
    -------
    Progress
        ``progress(message)``; the time is seconds since this call, flushed at once; a step
        longer than ``HEARTBEAT_S`` is said to be still running.
    """
    return Progress(command)


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
        say(f"batlab {command}: {message}", file=sys.stderr)

    return note


class _DeprecatedAlias(argparse.Action):
    """Store like the new option, with one deprecation line on stderr (hidden from --help)."""

    def __init__(self, option_strings, dest, new: str = "", **kwargs):
        super().__init__(option_strings, dest, default=argparse.SUPPRESS, help=argparse.SUPPRESS,
                         **kwargs)
        self.new = new

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"{parser.prog}: warning: {option_string} is deprecated and goes in the next "
              f"release: use {self.new}", file=sys.stderr)
        setattr(namespace, self.dest, self.const if values is None and self.nargs == 0
                else values)


def add_deprecated_alias(p: argparse.ArgumentParser, old: str, new: str, dest: str,
                         **kwargs) -> None:
    """Keep an old option spelling for one release: it works, warns on stderr, is not listed.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    old : str
        The old spelling, e.g. ``"--plot"``.
    new : str
        The new spelling the warning names, e.g. ``"--plots DIR"``.
    dest : str
        The new option's ``dest``, set by the old spelling too.
    **kwargs
        ``type``, ``nargs``, ``const`` as the old option had them.
    """
    p.add_argument(old, dest=dest, action=_DeprecatedAlias, new=new, **kwargs)


def add_out_argument(p: argparse.ArgumentParser, help_text: str, metavar: str = "PATH",
                     old: str | None = None, default=None) -> None:
    """Add ``-o/--out``, the file or folder a command writes (``old``: a deprecated spelling).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    help_text : str
        What is written there.
    metavar : str
        The value's name in the help.
    old : str or None
        An old spelling kept for one release (``add_deprecated_alias``).
    default : optional
        The value without the option.
    """
    p.add_argument("-o", "--out", default=default, metavar=metavar, help=help_text)
    if old:
        add_deprecated_alias(p, old, "-o/--out", "out")


def add_plots_argument(p: argparse.ArgumentParser, help_text: str, **kwargs) -> None:
    """Add ``--plots DIR``, the folder of a command's figures (old ``--plot`` kept one release).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    help_text : str
        Which figures are written there.
    **kwargs
        ``nargs``/``const`` of both spellings (paper: ``--plots`` alone is ./paper_figures).
    """
    p.add_argument("--plots", default=None, metavar="DIR", help=help_text, **kwargs)
    add_deprecated_alias(p, "--plot", "--plots DIR", "plots", **kwargs)
