"""The `batlab` command line: one sub-command per module `batlab/commands/<name>.py`.

Each command module defines ``HELP`` (one line), ``EXAMPLE`` (one command line, shown
under its ``--help``), ``add_arguments(parser)`` and
``run(args) -> int``. Modules import heavy dependencies inside ``run`` so that
``batlab --help`` stays fast. Bad input raises ``ValueError`` or ``OSError`` with a
message that names the file and the problem; it is printed as one line on stderr and
the exit code is 2.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sqlite3
import sys

# batlab's matrices are small (tens to hundreds of DOFs): BLAS threads cost more than they
# save, and under load they slow an eigen-solution several times. Set before numpy loads.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

COMMANDS: tuple[str, ...] = (
    "model",
    "simulate",
    "register",
    "bats",
    "history",
    "inspect",
    "report",
    "export",
    "registry",
    "demo",
    "diagnose",
    "rig",
    "acquire",
    "paper",
    "fit",
    "check-rig",
)


def build_parser() -> argparse.ArgumentParser:
    from batlab import __version__

    parser = argparse.ArgumentParser(
        prog="batlab",
        description="Detect altered wooden baseball bats from impact-hammer vibration tests.",
        epilog="example: batlab demo --out demo/   (then: batlab <command> --help)",
    )
    parser.add_argument("--version", action="version", version=f"batlab {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        module = importlib.import_module(f"batlab.commands.{name.replace('-', '_')}")
        example = getattr(module, "EXAMPLE", None)  # (tests/test_cli_consistency.py: required)
        p = sub.add_parser(name, help=module.HELP, description=module.HELP,
                           epilog=f"example:\n  {example}" if example else None,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except (ValueError, OSError) as exc:
        message = " ".join(str(exc).split()) or type(exc).__name__
        print(f"batlab {args.command}: error: {message}", file=sys.stderr)
        return 2
    except sqlite3.DatabaseError as exc:  # damage found after the registry opened
        db = getattr(args, "db", None) or "the registry"
        print(f"batlab {args.command}: error: {db}: registry damaged ({exc}); "
              "`batlab registry check` says where", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"batlab {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
