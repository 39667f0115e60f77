"""`batlab export`: the inspection history of one bat, or of the whole registry, as CSV."""

from __future__ import annotations

import argparse

from batlab.cli_support import add_db_argument, add_out_argument, note_printer, read_registry

EXAMPLE = "batlab export HX-1004 -o HX-1004.csv"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab export`` to its sub-parser."""
    p.add_argument("serial", nargs="?", default=None, help="one bat (default: every bat)")
    add_out_argument(p, "CSV file to write (required)", "FILE.csv", old="--output")
    add_db_argument(p)


def run(args: argparse.Namespace) -> int:
    """Write the inspection history (one bat or all) as a CSV file.

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
    from batlab.pipeline import admit, history_table, write_csv

    if not args.out:  # not argparse's required=: the old --output must satisfy it too
        raise ValueError("-o/--out FILE.csv is required (the CSV file to write)")
    admit(args, note_printer("export"), outputs={"out": "file"}, serial_label="SERIAL")
    with read_registry(args, "export") as conn:
        table = history_table(conn, args.serial)
    write_csv(args.out, table)
    print(f"{len(table)} inspection(s) written to {args.out}")
    return 0
