"""`batlab diagnose`: what the paper's model gets wrong about a bat's baseline test, and why."""

from __future__ import annotations

import argparse
import json
import sys

from batlab.cli_support import add_plots_argument, note_printer, progress_printer

EXAMPLE = "batlab diagnose --profile profile.csv --meta meta.json --frf baseline.uff --plots plots/"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab diagnose`` to its sub-parser."""
    p.add_argument("--profile", required=True, help="profile.csv (x_in,diameter_in)")
    p.add_argument("--meta", required=True, help="meta.json (handbook wood, weight_lb)")
    p.add_argument("--frf", required=True, help="baseline test (.uff, .csv or .npz)")
    p.add_argument("--json", action="store_true", help="print the JSON result on stdout")
    add_plots_argument(p, "write diagnose.png (percent frequency error per mode) into DIR")
    p.add_argument("--min-gain", type=float, default=None,
                   help="least RMS gain, percentage points, to name a cause (default 0.05)")
    p.add_argument("--method", choices=("lscf", "peak"), default="lscf",
                   help="modal estimation method of the ema fitter")
    p.add_argument("--solid", action="store_true",
                   help="also measure what the 1D beam misses against a 3D solid model of the "
                        "bat (about a minute; names beam_theory with its gain)")


def run(args: argparse.Namespace) -> int:
    """Compare a baseline test with the nominal model and calibrate the reference.

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
    from batlab import pipeline
    from batlab.diagnose_report import format_table, write_plot
    from batlab.report import check_destination

    pipeline.admit(args, note_printer("diagnose"), outputs={"plots": "dir"})
    progress = progress_printer("diagnose")
    meta, result = pipeline.diagnose_files(args.profile, args.meta, args.frf, args.method,
                                           args.min_gain, progress, solid=args.solid)
    out = result.to_json_dict()
    out["serial"] = meta.serial
    for w in result.warnings:
        print(f"batlab diagnose: warning: {w}", file=sys.stderr)
    if args.plots:  # created like every other output folder
        path = write_plot(result, check_destination(args.plots, "--plots") / "diagnose.png",
                          title=meta.serial)
        progress(f"wrote {path}")
    if args.json:
        print(json.dumps(out))
    else:
        print(format_table(out))
    return 0
