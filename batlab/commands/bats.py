"""`batlab bats`: the registered bats."""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict

from batlab.cli_support import add_db_argument, read_registry, say
from batlab.formatting import STATUS_WORDS

EXAMPLE = "batlab bats --db lab.sqlite"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab bats`` to its sub-parser."""
    add_db_argument(p)
    p.add_argument("--json", action="store_true", help="print JSON on stdout")


def run(args: argparse.Namespace) -> int:
    """List the registered bats with their latest inspection.

    Parameters
    ----------
    args : argparse.Namespace
        The options ``add_arguments`` defines.

    Returns
    -------
    int
        Exit code: 0 (bad input raises ValueError or OSError; ``batlab.cli`` prints
        it in one line and exits 2).
    """
    from batlab.registry import list_bats

    with read_registry(args, "bats") as conn:
        bats = list_bats(conn)
    if args.json:
        print(json.dumps([asdict(b) for b in bats]))
        return 0
    if not bats:
        say("no bats registered")
        return 0
    say(f"{'serial':<16} {'species':<14} {'registered (UTC)':<20} {'tests':>5}  latest")
    for b in bats:
        latest = "-" if b.last_status is None else (
            STATUS_WORDS.get(b.last_status, b.last_status) + f" ({b.last_inspected_at[:19]})")
        say(f"{b.serial:<16} {b.species:<14} {b.registered_at[:19]:<20} "
              f"{b.n_inspections:>5}  {latest}")
    return 0
