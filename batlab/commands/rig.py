"""`batlab rig serve`: the virtual acquisition box on a pseudo-terminal.

Prints the device path as the first stdout line, then streams until killed (or, with
--once, until the host has sent STOP). The structure is a uniform free-free beam computed in
closed form (Euler-Bernoulli: cos(bL) cosh(bL) = 1, mass-normalised shapes) hanging on a
soft suspension, unless --profile gives a bat profile: then updating's virtual bat (FE model,
Timoshenko, accelerometer mass, bungees; --alter drills and fills it) supplies the modes.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time

EXAMPLE = "batlab rig serve --profile profile.csv --meta meta.json --alter cork:depth=10,d=1.0"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab rig`` to its sub-parser."""
    parser.add_argument("action", choices=["serve"], help="serve: run the box")
    parser.add_argument("--profile", help="bat profile.csv (x_in,diameter_in) for the FE model "
                        "(default: a uniform beam)")
    parser.add_argument("--meta", help="meta.json (species values, points_in)")
    parser.add_argument("--alter", help="alteration of the bat, e.g. cork:depth=10,d=1.0")
    parser.add_argument("--faults", default="",
                        help="comma list of double,overload,weak,garbage,drop,bitflip,truncate")
    parser.add_argument("--fault-rate", type=float, default=0.3,
                        help="probability that a tap carries a fault (default 0.3)")
    parser.add_argument("--seed", type=int, default=0, help="random seed of taps and faults")
    parser.add_argument("--speed", type=float, default=1.0,
                        help="stream time per wall time; 0 = as fast as the host reads")
    parser.add_argument("--sample-rate", type=float, default=12800.0, help="Hz")
    parser.add_argument("--length-in", type=float, default=34.0, help="beam length, in")
    parser.add_argument("--mass-kg", type=float, default=0.9, help="beam mass, kg")
    parser.add_argument("--f1-hz", type=float, default=175.0, help="first bending mode, Hz")
    parser.add_argument("--points-in", default=None,
                        help="impact points from the knob end, in (default 1,3,...,31)")
    parser.add_argument("--accel-point", type=int, default=0,
                        help="point number carrying the accelerometer (default: the last; "
                        "with --profile the point nearest 1 in from the barrel end)")
    parser.add_argument("--tap-log", help="write one JSON line per tap (point, fault) here")
    parser.add_argument("--once", action="store_true", help="exit after the host's STOP")


def run(args: argparse.Namespace) -> int:
    """Serve the virtual acquisition box on a pseudo-terminal until stopped.

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
    import numpy as np

    from batlab import pipeline
    from batlab.cli_support import note_printer
    from batlab.pipeline import (
        DEFAULT_POINTS_IN,
        FAULTS,
        IN_TO_M,
        BoxConfig,
        VirtualBox,
        default_info,
    )

    pipeline.admit(args, note_printer("rig"), outputs={"tap_log": "file"})
    faults = tuple(f for f in args.faults.split(",") if f)
    unknown = [f for f in faults if f not in FAULTS]
    if unknown:
        raise ValueError(f"--faults: unknown fault(s) {', '.join(unknown)}")
    if args.meta and not args.points_in:
        points_in = pipeline.meta_points_m(args.meta) / IN_TO_M
        if not points_in.size:
            raise ValueError(f"{args.meta}: no points_in")
    elif args.points_in:
        try:
            points_in = np.array([float(v) for v in args.points_in.split(",")])
        except ValueError:
            raise ValueError(f"--points-in: not a list of numbers: {args.points_in}") from None
    else:
        points_in = np.array(DEFAULT_POINTS_IN)
    if args.profile:
        model, accel = pipeline.bat_modal_model(args.profile, args.meta, points_in * IN_TO_M,
                                                args.accel_point, args.alter,
                                                note_printer("rig"))
    else:
        if args.alter:
            raise ValueError("--alter needs --profile (the uniform beam cannot be altered)")
        model = pipeline.uniform_beam_model(args.length_in * IN_TO_M, args.mass_kg,
                                            args.f1_hz, points_in * IN_TO_M)
        accel = (args.accel_point or len(points_in)) - 1
    if not 0 <= accel < len(points_in):
        raise ValueError(f"--accel-point {args.accel_point} is not one of 1..{len(points_in)}")
    tap_log = open(args.tap_log, "w") if args.tap_log else None  # noqa: SIM115
    box = VirtualBox(BoxConfig(model, accel, default_info(args.sample_rate), faults,
                               args.fault_rate, args.seed, args.speed), tap_log)
    stopping = []
    signal.signal(signal.SIGTERM, lambda *_: stopping.append(True))
    print(box.device_path, flush=True)
    print(f"batlab rig: virtual box on {box.device_path}, {len(points_in)} points, "
          f"accelerometer at point {accel + 1}, faults: {', '.join(faults) or 'none'}",
          file=sys.stderr, flush=True)
    try:
        box.serve(lambda b: bool(stopping) or (args.once and b.stops > 0 and not b.pending_output))
        if args.once and not stopping:
            time.sleep(1.0)  # closing the master side drops what the host has not read yet
    finally:
        box.close()
        if tap_log:
            tap_log.close()
    return 0
