"""`batlab acquire`: roving-hammer test over a serial port (or a recorded raw stream).

Live: handshake with the box, for each point take --hits accepted hits, STOP, write the FRFs
(UFF, CSV or NPZ by extension, via ema.io.frf_io.write_test). Every byte from the box goes to
the raw stream file first, with a JSON sidecar holding the session settings so that
``--replay RAW`` re-runs the same path.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from pathlib import Path

from ema.io.atomic_write import atomic_write

HELP = "run a roving-hammer impact test over a serial port (or replay a recorded stream)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    src = parser.add_mutually_exclusive_group(required=True)
    src.add_argument("--port", help="serial port or pyserial URL of the acquisition box")
    src.add_argument("--replay", help="recorded raw stream (.raw.bin) to process again")
    parser.add_argument("--points", help="impact point numbers in order, e.g. 1,5,9")
    parser.add_argument("--driving-point", type=int,
                        help="point number of the accelerometer (response node)")
    parser.add_argument("--hits", type=int, help="accepted hits per point (default 3)")
    parser.add_argument("-o", "--output", help="FRF file to write (.uff)")
    parser.add_argument("--raw", help="raw stream file (default: OUTPUT with .raw.bin)")
    parser.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    parser.add_argument("--points-in", help="positions of points 1..n from the knob end, in")
    parser.add_argument("--meta", help="meta.json whose points_in gives the positions")
    parser.add_argument("--sample-rate", type=float, help="configure the box to this rate, Hz")
    parser.add_argument("--baud", type=int, default=921600)
    parser.add_argument("--record-s", type=float, default=2.0, help="record length, s")
    parser.add_argument("--pretrigger-s", type=float, default=0.01)
    parser.add_argument("--trigger-n", type=float, default=20.0, help="trigger level, N")
    parser.add_argument("--min-force-n", type=float, default=50.0,
                        help="weaker hits are rejected, N")
    parser.add_argument("--exp-window-tau", type=float, default=None,
                        help="exponential window time constant, s (default: none)")
    parser.add_argument("--fmax", type=float, default=3200.0, help="highest FRF line, Hz")
    parser.add_argument("--csv-info", help="JSON channel description: the box prints CSV lines")
    parser.add_argument("--timeout-s", type=float, default=2.0,
                        help="a silent device for this long is an error")


def _int_list(text: str, what: str) -> list[int]:
    try:
        return [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ValueError(f"{what}: not a list of integers: {text}") from None


def _positions_m(args: argparse.Namespace, points: list[int]) -> dict[int, float]:
    import numpy as np

    from batlab.commands.rig import DEFAULT_POINTS_IN, IN_TO_M

    if args.meta:
        try:
            pts = json.loads(Path(args.meta).read_text())["points_in"]
        except (OSError, KeyError, json.JSONDecodeError, TypeError) as exc:
            raise ValueError(f"{args.meta}: cannot read points_in ({exc})") from None
    elif args.points_in:
        pts = args.points_in.split(",")
    else:
        pts = DEFAULT_POINTS_IN
    try:
        x = np.asarray(pts, dtype=float) * IN_TO_M
    except ValueError:
        raise ValueError(f"point positions are not numbers: {pts}") from None
    bad = [n for n in points if not 1 <= n <= x.size]
    if bad:
        raise ValueError(f"points {bad} have no position (positions known for 1..{x.size})")
    return {n: float(x[n - 1]) for n in range(1, x.size + 1)}


def _write_json_atomic(path: Path, obj: dict) -> None:
    atomic_write(path, lambda tmp: tmp.write_text(json.dumps(obj, indent=1)))


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from rigs.capture import CaptureSettings
    from rigs.driver import ReplaySource, SerialDevice, open_port
    from rigs.protocol import device_info_from_dict
    from rigs.session import run_session

    def progress(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    side: dict = {}
    if args.replay:
        side_path = Path(args.replay + ".json")
        if side_path.exists():
            try:
                side = json.loads(side_path.read_text())
            except json.JSONDecodeError as exc:
                raise ValueError(f"{side_path}: not valid JSON ({exc.msg})") from None
    points = _int_list(args.points, "--points") if args.points else side.get("points")
    hits = args.hits or side.get("hits") or 3
    driving = args.driving_point or side.get("driving_point")
    if not points:
        raise ValueError("--points is required (no sidecar with the recorded session)")
    if not driving:
        raise ValueError("--driving-point is required")
    if driving not in points:
        raise ValueError(f"--driving-point {driving} is not one of the impact points")
    node_x = _positions_m(args, points + [driving])
    settings = CaptureSettings(args.trigger_n, args.trigger_n / 2, args.pretrigger_s,
                               args.record_s, args.min_force_n)
    if side.get("settings") and not args.port:
        settings = CaptureSettings(**side["settings"])
    tau = args.exp_window_tau if args.exp_window_tau is not None else side.get("exp_window_tau_s")
    csv_dict, csv_info = side.get("csv_info"), None
    if args.csv_info:
        try:
            csv_dict = json.loads(Path(args.csv_info).read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ValueError(f"{args.csv_info}: cannot read channel description ({exc})") from None
    if csv_dict:
        csv_info = device_info_from_dict(csv_dict, args.csv_info or "sidecar csv_info")

    if args.port:
        if not (args.raw or args.output):
            raise ValueError("give -o OUTPUT or --raw PATH: the raw stream must be saved")
        raw = Path(args.raw or Path(args.output).with_suffix(".raw.bin"))
        side = {"points": points, "hits": hits, "driving_point": driving,
                "settings": asdict(settings), "exp_window_tau_s": tau, "csv_info": csv_dict}
        _write_json_atomic(Path(str(raw) + ".json"), side)
        source = SerialDevice(open_port(args.port, args.baud), raw, csv_info,
                              silence_s=args.timeout_s)
    else:
        raw = Path(args.replay)
        source = ReplaySource(raw, csv_info)
    try:
        source.handshake(args.sample_rate)
        result = run_session(source, points, hits, settings, tau, args.fmax, progress)
        source.stop()
    finally:
        source.close()

    if args.port:
        _write_json_atomic(Path(str(raw) + ".json"), side | {"log": result.hits_as_dicts()})
    if args.output:
        from ema.io.frf_data import FrfTest
        from ema.io.frf_io import write_test

        out = Path(args.output)
        test = FrfTest(result.freq_hz, result.h1, [driving], result.points,
                       {n: node_x[n] for n in sorted(set(points) | {driving})},
                       coherence=result.coherence, exp_window_tau_s=tau,
                       meta={"source": "batlab acquire", "raw_stream": str(raw),
                             "device": result.info.name, "hits_per_point": hits})
        write_test(out, test)  # atomic (temporary name, then os.replace)
    rejected = [{"point": h.point, "hit": h.hit, "reason": h.reason, "detail": h.detail}
                for h in result.hits if not h.accepted]
    summary = {"accepted": int(sum(h.accepted for h in result.hits)), "rejected": rejected,
               "points": [int(v) for v in result.points], "driving_point": driving,
               "raw": str(raw), "output": args.output, "exp_window_tau_s": tau,
               "sample_rate_hz": result.info.sample_rate_hz,
               "n_averages": np.asarray(result.n_averages).tolist()}
    progress(f"batlab acquire: {summary['accepted']} hits accepted, {len(rejected)} rejected")
    if args.json:
        print(json.dumps(summary))
    return 0
