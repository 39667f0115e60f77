"""The `batlab` command line: one sub-command per module `batlab/cmd_<name>.py`.

Each command module defines ``HELP`` (one line), ``add_arguments(parser)`` and
``run(args) -> int``. Modules import heavy dependencies inside ``run`` so that
``batlab --help`` stays fast. Bad input raises ``ValueError`` or ``OSError`` with a
message that names the file and the problem; it is printed as one line on stderr and
the exit code is 2.
"""

from __future__ import annotations

import argparse
import importlib
import os
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
    "demo",
    "rig",
    "acquire",
    "paper",
)


BLAS_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def single_threaded_blas() -> None:
    """Default the BLAS thread pools to one thread; a user's own setting wins.

    batlab's linear algebra is many small dense problems (FE eigenproblems of ~100 DOF,
    least-squares steps); threaded OpenBLAS spends its time synchronising on them. On a loaded
    2-core machine `diagnose` of one bat took 27 s with 2 threads and 1.5 s with 1. Effective
    only before numpy is first imported, so ``main`` calls it first.
    """
    for var in BLAS_THREAD_VARS:
        os.environ.setdefault(var, "1")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="batlab",
        description="Detect altered wooden baseball bats from impact-hammer vibration tests.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        module = importlib.import_module(f"batlab.cmd_{name}")
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    single_threaded_blas()
    args = build_parser().parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except (ValueError, OSError) as exc:
        message = " ".join(str(exc).split()) or type(exc).__name__
        print(f"batlab {args.command}: error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"batlab {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
