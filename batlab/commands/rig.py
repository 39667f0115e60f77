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

import numpy as np

HELP = "run the virtual acquisition box (a simulated bat test) on a pseudo-terminal"

IN_TO_M = 0.0254
BETA_L = np.array([4.730040745, 7.853204624, 10.995607838, 14.137165491, 17.278759657,
                   20.420352245, 23.561944902, 26.703537556])
DEFAULT_POINTS_IN = tuple(np.arange(1.0, 32.0, 2.0))  # 16 marks, every 2 in from 1 in


def uniform_beam_modes(length_m: float, mass_kg: float, f1_hz: float, x_m: np.ndarray,
                       zeta1: float = 0.005, suspension_hz: tuple[float, float] = (2.0, 3.5),
                       n_bending: int = 8):
    """ModalModel of a free-free uniform beam at ``x_m``: two suspension (rigid) modes and
    ``n_bending`` bending modes, f_n = f1 (b_n L / b_1 L)^2, shapes
    phi_n(x) = [cosh bx + cos bx - s_n (sinh bx + sin bx)] / sqrt(m) with
    s_n = (cosh bL - cos bL) / (sinh bL - sin bL) (int_0^L phi^2 rho A dx = 1).
    Damping: 3 % on the suspension modes, zeta1 (f / f1)^0.3 on bending."""
    from rigs.modal_model import ModalModel

    x = np.asarray(x_m, dtype=float)[:, None]
    bl = BETA_L[:n_bending][None, :]
    b = bl / length_m
    s = (np.cosh(bl) - np.cos(bl)) / (np.sinh(bl) - np.sin(bl))
    bend = (np.cosh(b * x) + np.cos(b * x) - s * (np.sinh(b * x) + np.sin(b * x))) / np.sqrt(
        mass_kg)
    trans = np.full((x.shape[0], 1), 1 / np.sqrt(mass_kg))
    rot = np.sqrt(12 / (mass_kg * length_m**2)) * (x - length_m / 2)
    f_bend = f1_hz * (BETA_L[:n_bending] / BETA_L[0]) ** 2
    freq = np.r_[suspension_hz, f_bend]
    zeta = np.r_[0.03, 0.03, zeta1 * (f_bend / f1_hz) ** 0.3]
    return ModalModel(freq, zeta, np.hstack([trans, rot, bend]), x[:, 0])


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=["serve"], help="serve: run the box")
    parser.add_argument("--profile", help="bat profile.csv (x_in,diameter_in) for the FE model "
                        "(default: a uniform beam)")
    parser.add_argument("--meta", help="meta.json (species values, points_in)")
    parser.add_argument("--alter", help="alteration of the bat, e.g. cork:depth=10,d=1.0")
    parser.add_argument("--faults", default="",
                        help="comma list of double,overload,weak,garbage,drop,bitflip,truncate")
    parser.add_argument("--fault-rate", type=float, default=0.3,
                        help="probability that a tap carries a fault (default 0.3)")
    parser.add_argument("--seed", type=int, default=0)
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


def _profile_model(args: argparse.Namespace, points_m: np.ndarray):
    """ModalModel of a bat at ``points_m`` from its profile (updating's virtual bat: FE model,
    Timoshenko, 3 g accelerometer at the driving point, two 150 N/m bungees)."""
    from updating.model.lab_input import parse_core_spec, read_meta
    from updating.model.material import paper_material
    from updating.model.profile import read_profile_csv
    from updating.simulate.virtual_bat import VirtualBat, modal_model

    profile = read_profile_csv(args.profile)
    material = read_meta(args.meta).material if args.meta else paper_material()
    accel = (args.accel_point - 1) if args.accel_point else -1
    bat = VirtualBat(profile, material, points_m, sensor_index=accel, sensor_mass_kg=0.003,
                     bungee_k_n_per_m=150.0,
                     core=parse_core_spec(args.alter) if args.alter else None)
    modal, _ = modal_model(bat)
    return modal, bat.sensor_point()


def run(args: argparse.Namespace) -> int:
    from rigs.virtual_box import FAULTS, BoxConfig, VirtualBox, default_info

    faults = tuple(f for f in args.faults.split(",") if f)
    unknown = [f for f in faults if f not in FAULTS]
    if unknown:
        raise ValueError(f"--faults: unknown fault(s) {', '.join(unknown)}")
    if args.meta and not args.points_in:
        from updating.model.lab_input import read_meta
        from updating.model.units import IN_TO_M as in_to_m

        points_in = read_meta(args.meta).points_m / in_to_m
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
        model, accel = _profile_model(args, points_in * IN_TO_M)
    else:
        if args.alter:
            raise ValueError("--alter needs --profile (the uniform beam cannot be altered)")
        model = uniform_beam_modes(args.length_in * IN_TO_M, args.mass_kg, args.f1_hz,
                                   points_in * IN_TO_M)
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
