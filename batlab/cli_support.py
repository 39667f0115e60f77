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
                   help="registry file (default $BATLAB_DB, else "
                        "$XDG_DATA_HOME/batlab/registry.sqlite or "
                        "~/.local/share/batlab/registry.sqlite)")


def db_path(args: argparse.Namespace) -> Path:
    """Return the registry file: ``--db`` if given, else the default.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options of a command that called ``add_db_argument``.

    Returns
    -------
    Path
        ``--db`` with ``~`` expanded, else ``batlab.registry.default_db_path()``
        ($BATLAB_DB, else under $XDG_DATA_HOME or ~/.local/share).
    """
    from batlab.registry import default_db_path

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
