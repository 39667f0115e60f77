"""`batlab diagnose`: what the paper's model gets wrong about a bat's baseline test, and why."""

from __future__ import annotations

import json
import sys

HELP = "compare a baseline test with the nominal model, rank the causes, calibrate the reference"
EXAMPLE = "batlab diagnose --profile profile.csv --meta meta.json --frf baseline.uff --plot plots/"


def add_arguments(p) -> None:
    p.add_argument("--profile", required=True, help="profile.csv (x_in,diameter_in)")
    p.add_argument("--meta", required=True, help="meta.json (handbook wood, weight_lb)")
    p.add_argument("--frf", required=True, help="baseline test (.uff, .csv or .npz)")
    p.add_argument("--json", action="store_true", help="print the JSON result on stdout")
    p.add_argument("--plot", default=None, metavar="DIR",
                   help="write diagnose.png (percent frequency error per mode) into DIR")
    p.add_argument("--min-gain", type=float, default=None,
                   help="least RMS gain, percentage points, to name a cause (default 0.05)")
    p.add_argument("--method", choices=("lscf", "peak"), default="lscf",
                   help="modal estimation method of the ema fitter")


def modal_fitter():
    """ema.fit.fit_test, or a clear error when this installation lacks it."""
    try:
        from ema.fit import fit_test
    except ImportError:
        raise ValueError("the modal fitter (ema.fit) is not available in this "
                         "installation") from None
    return fit_test


def fit_modes(test, method: str, fit_test):
    """(MeasuredModes, suspension_hz) of a test by the ema fitter."""
    from updating.correlate.measured import from_fit

    i, _ = test.driving_point
    sensor_x_m = test.node_x_m[int(test.response_nodes[i])]
    fit = fit_test(test, method=method)
    suspension = getattr(fit, "suspension_freq_hz", None)
    return from_fit(fit, sensor_x_m), suspension


def run(args) -> int:
    from pathlib import Path

    from batlab.diagnose_report import format_table, write_plot
    from ema.io.frf_io import read_test
    from updating.diagnose.run import MIN_GAIN_PCT, diagnose
    from updating.model.lab_input import read_meta
    from updating.model.profile import read_profile_csv

    profile = read_profile_csv(args.profile)
    meta = read_meta(args.meta)
    if args.plot:  # created like every other output directory, and proved writable first
        from batlab.report import check_destination

        check_destination(args.plot, "--plot")
    test = read_test(args.frf)
    fit_test = modal_fitter()
    print(f"batlab diagnose: fitting the modes of {args.frf} ...", file=sys.stderr)
    measured, suspension_hz = fit_modes(test, args.method, fit_test)
    if measured.freq_hz.size == 0:
        raise ValueError(f"{args.frf}: the fitter found no elastic mode above 20 Hz")
    print(f"batlab diagnose: {measured.freq_hz.size} elastic modes; ranking the causes ...",
          file=sys.stderr)
    min_gain = MIN_GAIN_PCT if args.min_gain is None else args.min_gain
    result = diagnose(profile, meta, measured, suspension_hz, min_gain_pct=min_gain)
    out = result.to_json_dict()
    out["serial"] = meta.serial
    if args.plot:
        path = write_plot(result, Path(args.plot) / "diagnose.png", title=meta.serial)
        print(f"batlab diagnose: wrote {path}", file=sys.stderr)
    if args.json:
        print(json.dumps(out))
    else:
        print(format_table(out))
    return 0
