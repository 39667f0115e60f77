"""`batlab check-rig`: does a test of a reference bar match the bar (modes, damping, scaling).

The rig passes when the bar's measured modes, damping and mass line agree with its model.
"""

from __future__ import annotations

import argparse
import json
import sys

EXAMPLE = "batlab check-rig --bar steel_bar.json --frf bar_test.uff --json"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab check-rig`` to its sub-parser."""
    p.add_argument("--bar", required=True,
                   help="bar description (JSON: material E, density, length and section in "
                        "mm or m; docs/rig_check.md)")
    p.add_argument("--frf", required=True, help="test of the bar (.uff, .csv or .npz)")
    p.add_argument("--json", action="store_true", help="print the JSON result on stdout")
    p.add_argument("--freq-tol", type=float, default=None,
                   help="largest frequency error, %% (default 1.5)")
    p.add_argument("--max-damping", type=float, default=None,
                   help="largest damping ratio, %% (default 0.5)")
    p.add_argument("--scale-tol", type=float, default=None,
                   help="largest amplitude-scale and mass-line error, %% (default 10)")
    p.add_argument("--method", choices=("lscf", "peak"), default="lscf",
                   help="modal estimation method of the ema fitter")


def run(args: argparse.Namespace) -> int:
    """Check a test of a reference bar against the bar's model.

    Parameters
    ----------
    args : argparse.Namespace
        The options ``add_arguments`` defines.

    Returns
    -------
    int
        Exit code: 0 when the rig passes, 1 when a check fails (bad input raises
        ValueError or OSError; ``batlab.cli`` prints it in one line and exits 2).
    """
    from batlab import pipeline

    def progress(message: str) -> None:
        print(f"batlab check-rig: {message}", file=sys.stderr, flush=True)

    def fraction(pct: float | None) -> float | None:
        return None if pct is None else pct / 100

    pipeline.admit(args, progress)

    result = pipeline.check_rig_files(args.bar, args.frf, args.method, fraction(args.freq_tol),
                                      fraction(args.max_damping), fraction(args.scale_tol),
                                      progress)
    out = result.to_json_dict()
    if args.json:
        print(json.dumps(out))
    else:
        print("mode  model_hz  measured_hz  error_%  damping_%  scale    MAC")
        for k, m in enumerate(out["modes"], 1):
            print(f"{k:4d}  {m['model_hz']:8.1f}  {m['measured_hz']:11.1f}  "
                  f"{m['error_pct']:+7.2f}  {m['damping_pct']:9.3f}  {m['scale']:.3f}  "
                  f"{m['mac']:.3f}")
        for c in out["checks"]:
            print(f"{'ok  ' if c['ok'] else 'FAIL'}  {c['name']:<16} {c['text']}")
        print("rig check: " + ("PASSED" if result.ok else "FAILED"))
    return 0 if result.ok else 1
