"""`batlab model`: pre-test analysis of a bat (FE model, mass properties, modes, test points)."""

from __future__ import annotations

import argparse
import json
import sys

from batlab.cli_support import add_deprecated_alias

EXAMPLE = "batlab model --profile profile.csv --meta meta.json --beam timoshenko --json"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab model`` to its sub-parser."""
    p.add_argument("--profile", help="profile.csv (x_in,diameter_in); default: the paper's bat")
    p.add_argument("--meta", help="meta.json for the wood (default: the paper's white birch, "
                                  "said on stderr)")
    p.add_argument("--beam", choices=("euler", "timoshenko"), default="euler",
                   help="beam theory: euler (Euler-Bernoulli, the paper's) or timoshenko "
                        "(shear and rotary inertia)")
    p.add_argument("--e-over-g", type=float, default=None,
                   help="the wood's E/G, for timoshenko (default 14, as simulate and rig)")
    p.add_argument("--rotary-inertia", choices=("on", "off"), default=None,
                   help="default: on for timoshenko, off for euler")
    p.add_argument("--elements", type=int, default=None, help="number of elements (default ~1 in)")
    p.add_argument("--alter", default=None, help="e.g. cork:depth=10,d=1.0,ratio=0.33,plug=1 (in)")
    p.add_argument("--modes", type=int, default=8, help="number of modes to list (incl. rigid)")
    add_deprecated_alias(p, "--points", "--n-points N", "n_points", type=int)
    p.add_argument("--n-points", type=int, default=16, metavar="N",
                   help="number of test points to suggest (default 16; the barrel's last 14 in "
                        "get a row every 1.5-2 in, the accelerometer 1.5 in from the end)")
    p.add_argument("--json", action="store_true", help="print JSON on stdout")


def run(args: argparse.Namespace) -> int:
    """Build a bat's FE model and print its mass properties, modes and test points.

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
    from batlab.cli_support import note_printer

    pipeline.admit(args, note_printer("model"))
    profile = pipeline.bat_profile(args.profile)
    material = pipeline.wood(args.meta, args.e_over_g, note_printer("model"))
    rotary = None if args.rotary_inertia is None else args.rotary_inertia == "on"
    model = pipeline.bat_model(profile, material, beam=args.beam, rotary_inertia=rotary,
                               n_elements=args.elements, alter=args.alter)
    out = pipeline.summarise_model(model, n_modes=args.modes, n_points=args.n_points)
    if args.json:
        print(json.dumps(out))
    else:
        print(f"{out['n_elements']} elements, {out['ndof']} DOF, {args.beam} beam", file=sys.stdout)
        print(f"weight {out['weight_lb']:.4f} lb, centre of mass {out['cg_in']:.3f} in "
              f"from the knob, I_knob {out['moi_knob_lb_in2']:.1f} lb in^2, "
              f"I_cg {out['moi_cg_lb_in2']:.1f} lb in^2")
        print("mode  frequency_hz")
        for i, f in enumerate(out["frequencies_hz"], 1):
            print(f"{i:4d}  {f:12.2f}")
        pts = ", ".join(f"{x:.1f}" for x in out["suggested_points_in"])
        print(f"suggested test points (in from the knob): {pts}")
        print(f"accelerometer (driving point) at {out['driving_point_in']:.1f} in")
    return 0
