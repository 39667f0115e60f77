"""`batlab history`: the inspections of one registered bat."""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict

from batlab.cli_support import add_db_argument, note_printer, read_registry, say
from batlab.formatting import STATUS_WORDS, p_value_words

EXAMPLE = "batlab history HX-1004 --json"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab history`` to its sub-parser."""
    p.add_argument("serial", help="the bat's serial number")
    add_db_argument(p)
    p.add_argument("--json", action="store_true", help="print JSON on stdout")


def run(args: argparse.Namespace) -> int:
    """List the inspections of a registered bat, oldest first.

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
    from batlab.pipeline import admit
    from batlab.registry import get_bat, history

    admit(args, note_printer("history"), serial_label="SERIAL")
    with read_registry(args, "history") as conn:
        bat = get_bat(conn, args.serial)
        rows = history(conn, args.serial)
    if args.json:
        print(json.dumps({"serial": bat.serial, "registered_at": bat.registered_at,
                          "baseline_sha256": bat.baseline_sha256,
                          "inspections": [asdict(r) for r in rows]}))
        return 0
    say(f"{bat.serial}: registered {bat.registered_at[:19]} UTC, baseline {bat.baseline_name}")
    if not rows:
        say("  no inspections")
    for r in rows:
        v = r.verdict
        what = STATUS_WORDS.get(r.status, r.status)
        if r.status == "altered" and v.get("region_in"):
            what += f" at {v['region_in'][0]:.1f}-{v['region_in'][1]:.1f} in"
        said = p_value_words(v)
        p_s = "" if said is None else f", {said}"
        against = "" if r.reference_seq is None else f", against registration #{r.reference_seq}"
        say(f"  #{r.id} {r.inspected_at[:19]} {r.retest_name or r.retest_sha256[:12]}: "
              f"{what}{p_s}{against}" + (f", report {r.report_path}" if r.report_path else ""))
    return 0
