"""`batlab report`: regenerate a stored inspection's report from the registry alone."""

from __future__ import annotations

import argparse

from batlab.cli_support import (
    add_db_argument,
    add_out_argument,
    note_printer,
    progress_printer,
    read_registry,
)

EXAMPLE = "batlab report HX-1004 --inspection 3 -o report-HX-1004-3"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab report`` to its sub-parser."""
    p.add_argument("serial", help="the bat's serial number")
    p.add_argument("--inspection", type=int, default=None, metavar="N",
                   help="inspection number (see `batlab history S`; default the latest)")
    add_out_argument(p, "write DIR/index.html (default ./report-SERIAL-N)", "DIR")
    p.add_argument("--plots", default=None, metavar="DIR",
                   help="also write the figures as PNG files to DIR")
    p.add_argument("--pdf", action="store_true",
                   help="also print the page to DIR/report.pdf with headless Chromium "
                        "($BATLAB_CHROMIUM, else chromium on PATH)")
    add_db_argument(p)


def run(args: argparse.Namespace) -> int:
    """Regenerate the report of a stored inspection from the registry.

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
    from pathlib import Path

    from batlab import pipeline
    from batlab.registry import history
    from batlab.report import check_destination, find_chromium, write_pdf, write_report

    pipeline.admit(args, note_printer("report"), outputs={"out": "dir", "plots": "dir"},
                   serial_label="SERIAL")
    if args.pdf:
        find_chromium()  # before any work: without a browser, say so at once
    progress = progress_printer("report")
    with read_registry(args, "report") as conn:
        rows = history(conn, args.serial)
        n = args.inspection if args.inspection is not None else (rows[-1].id if rows else 0)
        out = Path(args.out) if args.out else Path(f"report-{args.serial}-{n}")
        check_destination(out, "--out")
        if args.plots:
            check_destination(args.plots, "--plots")
        inputs = pipeline.stored_report_inputs(conn, args.serial, args.inspection, progress)
    path = write_report(out, inputs, plots_dir=args.plots)
    pv = inputs.provenance
    progress(f"inspection {pv['bat_inspection']} of {args.serial} (registry inspection "
             f"#{pv['inspection_id']})")
    print(path)
    if args.pdf:
        print(write_pdf(path))
    return 0
