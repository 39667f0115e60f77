"""`batlab check-rig`: does a test of a reference bar match the bar (modes, damping, scaling)?"""

from __future__ import annotations

import json
import sys

HELP = ("check the test rig on a reference bar: measured modes, damping and mass line "
        "against the bar's model")


def add_arguments(p) -> None:
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


def run(args) -> int:
    import numpy as np

    from batlab.commands.diagnose import modal_fitter
    from ema.io.frf_io import read_test
    from updating.correlate.measured import from_fit
    from updating.diagnose.rig_check import FREQ_TOL, MAX_DAMPING, SCALE_TOL, check_rig
    from updating.model.bar import read_bar_json

    bar = read_bar_json(args.bar)
    test = read_test(args.frf)
    fit_test = modal_fitter()
    print(f"batlab check-rig: fitting the modes of {args.frf} ...", file=sys.stderr)
    i, _ = test.driving_point
    sensor_x_m = test.node_x_m[int(test.response_nodes[i])]
    fit = fit_test(test, method=args.method)
    measured = from_fit(fit, sensor_x_m)
    if measured.freq_hz.size == 0:
        raise ValueError(f"{args.frf}: the fitter found no elastic mode above 20 Hz")
    ml = getattr(fit, "mass_line", None)
    ml_dp = None
    if ml is not None and np.size(ml):
        ml_dp = float(np.real(np.asarray(ml)[fit.driving_frf]))
    result = check_rig(
        bar, measured, ml_dp if ml_dp and ml_dp > 0 else None,
        freq_tol=FREQ_TOL if args.freq_tol is None else args.freq_tol / 100,
        max_damping=MAX_DAMPING if args.max_damping is None else args.max_damping / 100,
        scale_tol=SCALE_TOL if args.scale_tol is None else args.scale_tol / 100)
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
