"""`batlab acquire`: roving-hammer test over a serial port (or a recorded raw stream).

Live: handshake with the box, for each point take --hits accepted hits, STOP, write the FRFs
(UFF, CSV or NPZ by extension; ``batlab.pipeline.acquisition``). Every byte from the box goes to
the raw stream file first, with a JSON sidecar holding the session settings so that
``--replay RAW`` re-runs the same path.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from pathlib import Path

EXAMPLE = ("batlab acquire --port /dev/ttyACM0 --points 1,3,5,7,9,11,13,15,16 "
           "--driving-point 16 --hits 3 --meta meta.json -o test.uff")


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
    parser.add_argument("--baud", type=int, default=921600,
                        help="serial speed, baud (ignored by USB CDC boards)")
    parser.add_argument("--record-s", type=float, default=2.0, help="record length, s")
    parser.add_argument("--pretrigger-s", type=float, default=0.01,
                        help="record kept before the trigger, s")
    parser.add_argument("--trigger-n", type=float, default=20.0, help="trigger level, N")
    parser.add_argument("--min-force-n", type=float, default=50.0,
                        help="weaker hits are rejected, N")
    parser.add_argument("--exp-window-tau", type=float, default=None,
                        help="exponential window time constant, s (default: none)")
    parser.add_argument("--fmax", type=float, default=3200.0, help="highest FRF line, Hz")
    parser.add_argument("--csv-info", help="JSON channel description: the box prints CSV lines")
    parser.add_argument("--timeout-s", type=float, default=2.0,
                        help="a silent device for this long is an error")
    parser.add_argument("--resume", action="store_true",
                        help="continue a killed session (same --raw/-o): its completed points "
                             "are kept, the rest are measured")
    parser.add_argument("--partial", action="store_true",
                        help="with --replay of a cut recording: write the completed points")


def _int_list(text: str, what: str) -> list[int]:
    try:
        return [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ValueError(f"{what}: not a list of integers: {text}") from None


def _positions_m(args: argparse.Namespace, points: list[int], side: dict) -> dict[int, float]:
    """Point positions (m) by point number: --meta's points_in, else --points-in, else the
    recorded session's sidecar, else the default marks (every 2 in from 1 in)."""
    import numpy as np

    from batlab.pipeline import DEFAULT_POINTS_IN, IN_TO_M

    where = "default marks"
    if args.meta:
        try:
            pts = json.loads(Path(args.meta).read_text())["points_in"]
        except (OSError, KeyError, json.JSONDecodeError, TypeError) as exc:
            raise ValueError(f"{args.meta}: cannot read points_in ({exc})") from None
        where = args.meta
    elif args.points_in:
        pts, where = args.points_in.split(","), "--points-in"
    elif side.get("points_in"):
        pts, where = side["points_in"], "the recorded session's sidecar (points_in)"
    else:
        pts = DEFAULT_POINTS_IN
    try:
        x = np.asarray(pts, dtype=float) * IN_TO_M
    except ValueError:
        raise ValueError(f"{where}: point positions are not numbers: {pts}") from None
    bad = [n for n in points if not 1 <= n <= x.size]
    if bad:
        raise ValueError(f"points {bad} have no position in {where} (positions known for "
                         f"1..{x.size})")
    return {n: float(x[n - 1]) for n in range(1, x.size + 1)}


def _read_sidecar(path: Path, required: bool) -> dict:
    if not path.exists():
        if required:
            raise ValueError(f"{path}: no recorded session there to resume")
        return {}
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not valid JSON ({exc.msg})") from None


def _resume_raw(raw: Path) -> Path:
    """The next free continuation file of a raw stream: RAW.resume1, RAW.resume2, ..."""
    k = 1
    while Path(f"{raw}.resume{k}").exists():
        k += 1
    return Path(f"{raw}.resume{k}")


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from batlab.pipeline import (
        IN_TO_M,
        CaptureSettings,
        ReplaySource,
        SerialDevice,
        SessionInterrupted,
        combine,
        device_info_from_dict,
        load_points,
        open_port,
        run_session,
        save_points,
        write_json_atomic,
        write_session_test,
    )

    def progress(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    if args.replay and not args.output:
        raise ValueError("--replay needs -o OUTPUT (the FRF file to write from the recording)")
    if args.resume and not args.port:
        raise ValueError("--resume continues a live session: give --port too")
    if args.port and not (args.raw or args.output):
        raise ValueError("give -o OUTPUT or --raw PATH: the raw stream must be saved")
    if args.partial and not args.replay:
        raise ValueError("--partial applies to --replay (a live session saves its points)")
    raw = Path(args.replay) if args.replay else Path(
        args.raw or Path(args.output).with_suffix(".raw.bin"))
    side_path = Path(str(raw) + ".json")
    side = _read_sidecar(side_path, required=bool(args.resume)) if (
        args.replay or args.resume) else {}
    points = _int_list(args.points, "--points") if args.points else side.get("points")
    if args.resume and args.points and points != side.get("points"):
        raise ValueError(f"--points {args.points} differs from the session being resumed "
                         f"({side_path}: {side.get('points')})")
    hits = args.hits or side.get("hits") or 3
    driving = args.driving_point or side.get("driving_point")
    if not points:
        raise ValueError("--points is required (no sidecar with the recorded session)")
    if not driving:
        raise ValueError("--driving-point is required")
    if driving not in points:
        raise ValueError(f"--driving-point {driving} is not one of the impact points")
    node_x = _positions_m(args, points + [driving], side)
    settings = CaptureSettings(args.trigger_n, args.trigger_n / 2, args.pretrigger_s,
                               args.record_s, args.min_force_n)
    if side.get("settings") and (args.replay or args.resume):
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
    if args.output:
        out = Path(args.output)
        if out.parent and not out.parent.is_dir():
            raise ValueError(f"{out}: output directory {out.parent} does not exist")

    points_file = Path(str(raw) + ".points.npz")
    done = load_points(points_file, tau) if args.resume else {}
    log_before = list(side.get("log") or []) if args.resume else []
    resumed = sorted(done)
    if args.port:
        seg = _resume_raw(raw) if args.resume else raw
        port = open_port(args.port, args.baud)  # a missing port fails here: nothing written
        positions_in = [round(node_x[n] / IN_TO_M, 4) for n in range(1, len(node_x) + 1)]
        side = {"points": points, "hits": hits, "driving_point": driving,
                "settings": asdict(settings), "exp_window_tau_s": tau, "csv_info": csv_dict,
                "points_in": positions_in, "points_file": points_file.name,
                "completed": sorted(done), "segments": side.get("segments", [raw.name])
                + ([seg.name] if args.resume else []), "log": log_before}
        write_json_atomic(side_path, side)
        source = SerialDevice(port, seg, csv_info, silence_s=args.timeout_s)
    else:
        source = ReplaySource(raw, csv_info)

    def on_point(point: int, est, log) -> None:
        done[point] = est
        if args.port:  # completed points and their hit log are on disk as they complete
            save_points(points_file, done)
            write_json_atomic(side_path, side | {"completed": sorted(done), "log": log_before
                                                  + [asdict(h) for h in log]})

    interrupted: SessionInterrupted | None = None
    try:
        source.handshake(args.sample_rate)
        result = run_session(source, points, hits, settings, tau, args.fmax, progress,
                             done=done, on_point=on_point)
        source.stop()
    except SessionInterrupted as exc:
        interrupted = exc
    except KeyboardInterrupt:
        if args.port:
            progress(f"batlab acquire: interrupted; {len(done)} of {len(points)} points saved "
                     f"in {points_file}: continue with batlab acquire --port PORT --resume "
                     f"--raw {raw}" + (f" -o {args.output}" if args.output else ""))
        raise
    finally:
        source.close()
    if interrupted is not None:
        log = log_before + [asdict(h) for h in interrupted.log]
        if args.port:
            write_json_atomic(side_path, side | {"completed": sorted(done), "log": log})
            raise ValueError(f"{interrupted}; {len(done)} of {len(points)} points saved in "
                             f"{points_file}: continue with batlab acquire --port PORT "
                             f"--resume --raw {raw}"
                             + (f" -o {args.output}" if args.output else "")) from None
        completed = [n for n in points if n in interrupted.completed]
        if not (args.partial and completed):
            raise ValueError(f"{interrupted} after {len(completed)} of {len(points)} points "
                             "(completed: " + (", ".join(map(str, completed)) or "none") + ")"
                             + ("; add --partial to write them" if completed else "")) from None
        progress(f"batlab acquire: recording ends after {len(completed)} of {len(points)} "
                 f"points: writing points {', '.join(map(str, completed))}")
        points = completed
        result = combine(points, interrupted.completed, tau, interrupted.log, interrupted.info)
        if driving not in points:
            raise ValueError(f"{raw}: the driving point {driving} was not completed: "
                             "the partial test has no driving point") from None

    log_all = log_before + result.hits_as_dicts()
    if args.port:
        write_json_atomic(side_path, side | {"completed": sorted(done), "log": log_all})
    if args.output:  # atomic (temporary name, then os.replace)
        write_session_test(Path(args.output), result, points, driving, node_x, tau, raw, hits)
    rejected = [{"point": h["point"], "hit": h["hit"], "reason": h["reason"],
                 "detail": h["detail"]} for h in log_all if not h["accepted"]]
    summary = {"accepted": int(sum(h["accepted"] for h in log_all)), "rejected": rejected,
               "points": [int(v) for v in result.points], "driving_point": driving,
               "raw": str(raw), "output": args.output, "exp_window_tau_s": tau,
               "sample_rate_hz": result.info.sample_rate_hz,
               "n_averages": np.asarray(result.n_averages).tolist(),
               "resumed_points": resumed}
    progress(f"batlab acquire: {summary['accepted']} hits accepted, {len(rejected)} rejected")
    if args.json:
        print(json.dumps(summary))
    return 0
