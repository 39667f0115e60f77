"""`batlab paper`: rerun the paper's corked-bat case (SEREP, MSSO, then batlab's refinement)."""

from __future__ import annotations

import argparse
import json

from batlab.cli_support import add_plots_argument, progress_printer

EXAMPLE = "batlab paper --json"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab paper`` to its sub-parser."""
    p.add_argument("--noise", type=float, default=0.0, metavar="PCT",
                   help="noise on shape entries, %% of each mode's RMS (frequencies 0.05 %%)")
    p.add_argument("--seed", type=int, default=0, help="noise seed")
    p.add_argument("--modes", type=int, default=6, help="elastic modes used (default 6)")
    p.add_argument("--json", action="store_true", help="print JSON on stdout")
    add_plots_argument(p, "write Figures 2 and 3 as PNG into DIR (default DIR: "
                          "paper_figures)", nargs="?", const="paper_figures")


def run(args: argparse.Namespace) -> int:
    """Rerun the paper's corked-bat case, then batlab's refinement.

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
    from batlab.pipeline import PAPER, TRUE, element_rows, plot_figures, run_paper_case

    if args.noise < 0 or not 2 <= args.modes <= 10:
        raise ValueError("--noise must be >= 0 and --modes between 2 and 10")
    progress = progress_printer("paper")
    progress("running SEREP + MSSO + refinement on the paper's bat")
    case = run_paper_case(args.modes, args.noise, args.seed)
    progress("done")
    if args.plots:
        for path in plot_figures(case, args.plots):
            progress(f"wrote {path}")
    if args.json:
        out = dict(case.final)
        out["modes_used"] = args.modes
        out["one_pass"] = case.one_pass
        out["elements"] = element_rows(case.reference, case.update.factors)
        print(json.dumps(out))
        return 0
    print(f"paper's corked bat, {args.modes} modes at 34 translational DOFs, "
          f"noise {args.noise:g} %")
    print(f"{'':22s}{'true':>9s}{'paper':>9s}{'one pass':>10s}{'batlab':>9s}")
    for key, name in (("alpha_mean", "mean alpha (24-32)"), ("beta_mean", "mean beta (24-32)"),
                      ("core_diameter_in", "core diameter, in"),
                      ("density_ratio", "fill density ratio")):
        print(f"{name:22s}{TRUE[key]:9.4f}{PAPER[key]:9.4f}{case.one_pass[key]:10.4f}"
              f"{case.final[key]:9.4f}")
    reg = case.final["region_found_in"]
    print("changed region found: " + (f"{reg[0]:.0f}-{reg[1]:.0f} in from the knob (true 23-32)"
                                      if reg else "none"))
    return 0
