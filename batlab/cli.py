"""The `batlab` command line: one sub-command per module `batlab/commands/<name>.py`.

``COMMANDS`` maps each command's name to its module and one-line help, so ``batlab --help``
lists the commands without importing any of them, and ``batlab CMD ...`` imports CMD's module
alone. A command module defines ``EXAMPLE`` (one command line, shown under its ``--help``),
``add_arguments(parser)`` and ``run(args) -> int``, and imports heavy dependencies inside
``run``; a command checks its options and files first (``batlab.pipeline.door.admit``). Bad
input raises ``ValueError`` or ``OSError`` with a message that names the file and the
problem; it is printed as one line on stderr and the exit code is 2. Warnings (numpy's,
scipy's) never reach the user: a failure they foretell is that one line, and a run that
succeeds checked its results itself (``python -W default -m batlab ...`` shows them).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sqlite3
import sys
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

# batlab's matrices are small (tens to hundreds of DOFs): BLAS threads cost more than they
# save, and under load they slow an eigen-solution several times. Set before numpy loads.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")


@dataclass(frozen=True)
class Command:
    """Where a sub-command lives and what it does, known without importing it.

    Parameters
    ----------
    module : str
        Dotted name of the module defining ``EXAMPLE``, ``add_arguments`` and ``run``.
    help : str
        One line, shown by ``batlab --help`` and at the top of ``batlab CMD --help``.
    """

    module: str
    help: str


def _command(name: str, one_line: str) -> Command:
    return Command(f"batlab.commands.{name.replace('-', '_')}", one_line)


COMMANDS: dict[str, Command] = {
    "model": _command("model", "build a bat's FE model from its profile: mass properties, "
                               "free-free modes, test points"),
    "simulate": _command("simulate", "simulate an impact test of a bat on the virtual rig and "
                                     "write it (UFF, CSV or NPZ)"),
    "register": _command("register", "register a bat: fit its baseline test, calibrate its "
                                     "reference, store it by serial"),
    "bats": _command("bats", "list the registered bats with their latest inspection"),
    "history": _command("history", "list the inspections of a registered bat, oldest first"),
    "inspect": _command("inspect", "inspect a re-test of a bat for alteration (stateless, or "
                                   "against the registry)"),
    "report": _command("report", "regenerate the report of a stored inspection from the "
                                 "registry (files kept there)"),
    "lab": _command("lab", "set or show the lab profile (name, operator, equipment) that "
                           "reports print"),
    "export": _command("export", "write the inspection history (one bat or all) as a CSV file"),
    "registry": _command("registry", "check the registry (SQLite integrity, stored files, "
                                     "the signed custody chain); print the lab's public key "
                                     "or the chain's head"),
    "demo": _command("demo", "simulate a baseline and a corked re-test of a built-in bat, "
                             "register and inspect them"),
    "diagnose": _command("diagnose", "compare a baseline test with the nominal model, rank the "
                                     "causes, calibrate the reference"),
    "rig": _command("rig", "run the virtual acquisition box (a simulated bat test) on a "
                           "pseudo-terminal"),
    "acquire": _command("acquire", "run a roving-hammer impact test over a serial port (or "
                                   "replay a recorded stream)"),
    "paper": _command("paper", "rerun the paper's corked-bat case: SEREP + MSSO as published, "
                               "then batlab's refinement"),
    "fit": _command("fit", "fit natural frequencies, damping and mass-normalised mode shapes "
                           "to a test's FRFs"),
    "fleet": _command("fleet", "inspect a folder of re-tests, or calibrate a bat's false-alarm "
                               "rate, on a Dask cluster"),
    "check-rig": _command("check-rig", "check the test rig on a reference bar: measured modes, "
                                       "damping and mass line against the bar's model"),
}
"""Every sub-command, in the order ``batlab --help`` lists them."""


def build_parser(wired: Iterable[str] | None = None) -> argparse.ArgumentParser:
    """Build the ``batlab`` parser, importing only the commands that are wired.

    Every command is listed (name and help, from ``COMMANDS``); a wired command also gets
    its options, its example and its ``run`` (its module is imported).

    Parameters
    ----------
    wired : iterable of str, optional
        Names of the commands to wire; None (the default) wires every command.

    Returns
    -------
    argparse.ArgumentParser
        The parser; ``parse_args`` puts the chosen command's ``run`` in ``args._run``.
    """
    wired = set(COMMANDS if wired is None else wired)
    parser = argparse.ArgumentParser(
        prog="batlab",
        description="Detect altered wooden baseball bats from impact-hammer vibration tests.",
        epilog="example: batlab demo -o demo/   (then: batlab <command> --help)",
    )
    parser.add_argument("--version", action=_Version, nargs=0,
                        help="print the version of the code (it differs for every commit)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, command in COMMANDS.items():
        p = sub.add_parser(name, help=command.help, description=command.help,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        if name in wired:
            _wire(p, command)
    return parser


class _Version(argparse.Action):
    """``--version``: print ``batlab VERSION`` and exit (the version looked up only then)."""

    def __call__(self, parser, namespace, values, option_string=None):
        from batlab.version import code_version

        print(f"batlab {code_version()}")
        parser.exit()


def _wire(p: argparse.ArgumentParser, command: Command) -> None:
    """Import a command's module and give its sub-parser the options, example and ``run``."""
    module = importlib.import_module(command.module)
    p.epilog = f"example:\n  {module.EXAMPLE}"  # (tests/test_cli_consistency.py: required)
    module.add_arguments(p)
    p.set_defaults(_run=module.run)


def chosen_command(argv: Sequence[str]) -> str | None:
    """Return the command an argument list chooses, or None when it chooses none.

    The top-level options (``-h``, ``--help``, ``--version``) take no value, so the first
    argument that is not an option names the command.

    Parameters
    ----------
    argv : sequence of str
        The arguments after the program name.

    Returns
    -------
    str or None
        A key of ``COMMANDS``, or None (no command, or an unknown one: argparse says so).
    """
    first = next((a for a in argv if not a.startswith("-")), None)
    return first if first in COMMANDS else None


def error_lines(exc: BaseException) -> str:
    """Return an error's message with each line's runs of white space made one space.

    A message is one line, or a few when it says what to check (indented by two spaces).

    Parameters
    ----------
    exc : BaseException
        The error.

    Returns
    -------
    str
        The message (the error's type name when it has none).
    """
    from batlab.safe_text import for_terminal

    lines = [" ".join(line.split()) for line in str(exc).splitlines() if line.strip()]
    return for_terminal("\n  ".join(lines), keep="\n") or type(exc).__name__


def _registry_of(args: argparse.Namespace):
    """Return the registry a command was working on (``--db``, else the default)."""
    from batlab.cli_support import db_path

    try:
        return db_path(args) if hasattr(args, "db") else None
    except ValueError:
        return getattr(args, "db", None)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``batlab`` command line.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments after the program name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit code: 0 done, 2 bad input (one line on stderr naming the file and the
        problem, or a few saying what to check), 130 interrupted; 1 when ``check-rig`` or
        ``registry check`` finds a fault.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    chosen = chosen_command(argv)
    args = build_parser(wired=() if chosen is None else (chosen,)).parse_args(argv)
    try:
        with warnings.catch_warnings():
            if not sys.warnoptions:  # python -W / PYTHONWARNINGS: a developer asks for them
                warnings.simplefilter("ignore")
            return int(args._run(args) or 0)
    except BrokenPipeError:  # stdout's reader left (`batlab bats | head -1`): no error line
        from batlab.cli_support import stdout_closed

        stdout_closed()
        return 141  # as a shell reports a writer killed by SIGPIPE (128 + 13)
    except (ValueError, OSError) as exc:
        print(f"batlab {args.command}: error: {error_lines(exc)}", file=sys.stderr)
        return 2
    except (OverflowError, FloatingPointError) as exc:  # a number no input check saw
        print(f"batlab {args.command}: error: a computation failed on the inputs' numbers "
              f"({error_lines(exc)}): check their units and scale", file=sys.stderr)
        return 2
    except sqlite3.DatabaseError as exc:  # an error after the registry opened: named
        from batlab.registry.faults import describe

        print(f"batlab {args.command}: error: {describe(_registry_of(args), exc)}",
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"batlab {args.command}: interrupted", file=sys.stderr)
        return 130
    finally:
        from batlab.cli_support import stop_all

        stop_all()  # no progress heartbeat outlives its command


if __name__ == "__main__":
    sys.exit(main())
