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
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from batlab.cli_support import add_out_argument

if TYPE_CHECKING:
    from batlab.pipeline import CaptureSettings

EXAMPLE = ("batlab acquire --port /dev/ttyACM0 --points 1,3,5,7,9,11,13,15,16 \\\n"
           "      --driving-point 16 --hits 3 --meta meta.json -o test.uff")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add `batlab acquire`'s flags to ``parser``."""
    src = parser.add_mutually_exclusive_group(required=True)
    src.add_argument("--port", help="serial port or pyserial URL of the acquisition box")
    src.add_argument("--replay", help="recorded raw stream (.raw.bin) to process again")
    parser.add_argument("--points", help="impact point numbers in order, e.g. 1,5,9")
    parser.add_argument("--driving-point", type=int,
                        help="point number of the accelerometer (response node)")
    parser.add_argument("--hits", type=int, help="accepted hits per point (default 3)")
    add_out_argument(parser, "FRF file to write (.uff)", "FILE.uff", old="--output")
    parser.add_argument("--raw", help="raw stream file (default: -o's with .raw.bin)")
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
    """Return the point positions (m) by point number.

    The positions are --meta's points_in, else --points-in, else the recorded session's
    sidecar's, else the default marks (every 2 in from 1 in).
    """
    import numpy as np

    from batlab.pipeline import DEFAULT_POINTS_IN, IN_TO_M, read_json_object

    where = "default marks"
    if args.meta:
        pts = read_json_object(args.meta).get("points_in")
        if pts is None:
            raise ValueError(f"{args.meta}: cannot read points_in (no key 'points_in')")
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
    from batlab.pipeline import read_json_object

    return read_json_object(path)


def _resume_raw(raw: Path) -> Path:
    """Return the next free continuation file of a raw stream: RAW.resume1, RAW.resume2, ..."""
    k = 1
    while Path(f"{raw}.resume{k}").exists():
        k += 1
    return Path(f"{raw}.resume{k}")


def _progress(msg: str) -> None:
    """Print a progress line on stderr."""
    print(msg, file=sys.stderr, flush=True)


def _check_flags(args: argparse.Namespace) -> None:
    """Raise ValueError for a combination of flags that cannot run."""
    if args.replay and not args.out:
        raise ValueError("--replay needs -o OUTPUT (the FRF file to write from the recording)")
    if args.resume and not args.port:
        raise ValueError("--resume continues a live session: give --port too")
    if args.port and not (args.raw or args.out):
        raise ValueError("give -o OUTPUT or --raw PATH: the raw stream must be saved")
    if args.partial and not args.replay:
        raise ValueError("--partial applies to --replay (a live session saves its points)")


@dataclass(frozen=True)
class _Plan:
    """What a session measures and how: flags, else the recorded session's sidecar."""

    raw: Path
    side_path: Path
    side: dict
    points: list[int]
    hits: int
    driving: int
    node_x: dict[int, float]
    settings: CaptureSettings
    tau: float | None
    csv_dict: dict | None
    csv_info: object


def _points_plan(args: argparse.Namespace, side: dict, side_path: Path
                 ) -> tuple[list[int], int, int]:
    """Return the impact points, the hits per point and the driving point of the session."""
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
    return points, hits, driving


def _channels(args: argparse.Namespace, side: dict) -> tuple[dict | None, object]:
    """Return the CSV channel description (--csv-info, else the sidecar's) as read and parsed."""
    from batlab.pipeline import device_info_from_dict, read_json_object

    csv_dict = read_json_object(args.csv_info) if args.csv_info else side.get("csv_info")
    if not csv_dict:
        return csv_dict, None
    return csv_dict, device_info_from_dict(csv_dict, args.csv_info or "sidecar csv_info")


def _plan(args: argparse.Namespace) -> _Plan:
    """Gather the session's plan from the flags and, for a replay or a resume, the sidecar."""
    from batlab.pipeline import CaptureSettings

    raw = Path(args.replay) if args.replay else Path(
        args.raw or Path(args.out).with_suffix(".raw.bin"))
    side_path = Path(str(raw) + ".json")
    side = _read_sidecar(side_path, required=bool(args.resume)) if (
        args.replay or args.resume) else {}
    points, hits, driving = _points_plan(args, side, side_path)
    node_x = _positions_m(args, points + [driving], side)
    settings = CaptureSettings(args.trigger_n, args.trigger_n / 2, args.pretrigger_s,
                               args.record_s, args.min_force_n)
    if side.get("settings") and (args.replay or args.resume):
        settings = CaptureSettings(**side["settings"])
    tau = args.exp_window_tau if args.exp_window_tau is not None else side.get("exp_window_tau_s")
    csv_dict, csv_info = _channels(args, side)
    if args.out:
        out = Path(args.out)
        if out.parent and not out.parent.is_dir():
            raise ValueError(f"{out}: output directory {out.parent} does not exist")
    return _Plan(raw, side_path, side, points, hits, driving, node_x, settings, tau, csv_dict,
                 csv_info)


def _open_live(args: argparse.Namespace, plan: _Plan, done: dict, log_before: list,
               points_file: Path):
    """Open the serial port and write the new session's sidecar.

    Returns
    -------
    source : SerialDevice
        The box, its bytes going to the raw stream (a continuation file when resuming).
    side : dict
        The sidecar written.
    """
    from batlab.pipeline import IN_TO_M, SerialDevice, open_port, write_json_atomic

    raw = plan.raw
    seg = _resume_raw(raw) if args.resume else raw
    port = open_port(args.port, args.baud)  # a missing port fails here: nothing written
    positions_in = [round(plan.node_x[n] / IN_TO_M, 4) for n in range(1, len(plan.node_x) + 1)]
    side = {"points": plan.points, "hits": plan.hits, "driving_point": plan.driving,
            "settings": asdict(plan.settings), "exp_window_tau_s": plan.tau,
            "csv_info": plan.csv_dict, "points_in": positions_in,
            "points_file": points_file.name, "completed": sorted(done),
            "segments": plan.side.get("segments", [raw.name])
            + ([seg.name] if args.resume else []), "log": log_before}
    write_json_atomic(plan.side_path, side)
    return SerialDevice(port, seg, plan.csv_info, silence_s=args.timeout_s), side


def _resume_hint(args: argparse.Namespace, raw: Path) -> str:
    """Return the command that continues a killed live session."""
    return (f"batlab acquire --port PORT --resume --raw {raw}"
            + (f" -o {args.out}" if args.out else ""))


def _partial_result(args: argparse.Namespace, plan: _Plan, interrupted):
    """Return the completed points of a cut recording and their session result (--partial).

    Raises ValueError when --partial is not given, nothing was completed or the driving
    point is missing.
    """
    from batlab.pipeline import combine

    points = plan.points
    completed = [n for n in points if n in interrupted.completed]
    if not (args.partial and completed):
        raise ValueError(f"{interrupted} after {len(completed)} of {len(points)} points "
                         "(completed: " + (", ".join(map(str, completed)) or "none") + ")"
                         + ("; add --partial to write them" if completed else "")) from None
    _progress(f"batlab acquire: recording ends after {len(completed)} of {len(points)} "
              f"points: writing points {', '.join(map(str, completed))}")
    result = combine(completed, interrupted.completed, plan.tau, interrupted.log,
                     interrupted.info)
    if plan.driving not in completed:
        raise ValueError(f"{plan.raw}: the driving point {plan.driving} was not completed: "
                         "the partial test has no driving point") from None
    return completed, result


def _measure(args: argparse.Namespace, plan: _Plan, done: dict, log_before: list,
             points_file: Path):
    """Run the session (live or replayed) and return its points, result and sidecar.

    A live session saves every completed point and its hit log as it completes; an
    interrupted one says how to resume; a cut replay gives its completed points with
    --partial.
    """
    from batlab.pipeline import (
        ReplaySource,
        SessionInterrupted,
        run_session,
        save_points,
        write_json_atomic,
    )

    side = plan.side
    if args.port:
        source, side = _open_live(args, plan, done, log_before, points_file)
    else:
        source = ReplaySource(plan.raw, plan.csv_info)

    def on_point(point: int, est, log) -> None:
        done[point] = est
        if args.port:  # completed points and their hit log are on disk as they complete
            save_points(points_file, done)
            write_json_atomic(plan.side_path, side | {"completed": sorted(done), "log":
                                                      log_before + [asdict(h) for h in log]})

    try:
        source.handshake(args.sample_rate)
        result = run_session(source, plan.points, plan.hits, plan.settings, plan.tau,
                             args.fmax, _progress, done=done, on_point=on_point)
        source.stop()
        return plan.points, result, side
    except SessionInterrupted as exc:
        interrupted = exc
    except KeyboardInterrupt:
        if args.port:
            _progress(f"batlab acquire: interrupted; {len(done)} of {len(plan.points)} points "
                      f"saved in {points_file}: continue with {_resume_hint(args, plan.raw)}")
        raise
    finally:
        source.close()
    if args.port:
        log = log_before + [asdict(h) for h in interrupted.log]
        write_json_atomic(plan.side_path, side | {"completed": sorted(done), "log": log})
        raise ValueError(f"{interrupted}; {len(done)} of {len(plan.points)} points saved in "
                         f"{points_file}: continue with {_resume_hint(args, plan.raw)}") from None
    points, result = _partial_result(args, plan, interrupted)
    return points, result, side


def _summary(args: argparse.Namespace, plan: _Plan, result, log_all: list[dict],
             resumed: list[int]) -> dict:
    """Return the JSON summary of a session: hits accepted and rejected, files, averages."""
    import numpy as np

    rejected = [{"point": h["point"], "hit": h["hit"], "reason": h["reason"],
                 "detail": h["detail"]} for h in log_all if not h["accepted"]]
    return {"accepted": int(sum(h["accepted"] for h in log_all)), "rejected": rejected,
            "points": [int(v) for v in result.points], "driving_point": plan.driving,
            "raw": str(plan.raw), "output": args.out, "exp_window_tau_s": plan.tau,
            "sample_rate_hz": result.info.sample_rate_hz,
            "n_averages": np.asarray(result.n_averages).tolist(),
            "resumed_points": resumed}


def run(args: argparse.Namespace) -> int:
    """Run `batlab acquire`: measure (or replay) a session and write its FRFs.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line (``add_arguments``).

    Returns
    -------
    int
        The exit code, 0.
    """
    from batlab.pipeline import load_points, write_json_atomic, write_session_test

    _check_flags(args)
    plan = _plan(args)
    points_file = Path(str(plan.raw) + ".points.npz")
    done = load_points(points_file, plan.tau) if args.resume else {}
    log_before = list(plan.side.get("log") or []) if args.resume else []
    resumed = sorted(done)
    points, result, side = _measure(args, plan, done, log_before, points_file)
    log_all = log_before + result.hits_as_dicts()
    if args.port:
        write_json_atomic(plan.side_path, side | {"completed": sorted(done), "log": log_all})
    if args.out:  # atomic (temporary name, then os.replace)
        write_session_test(Path(args.out), result, points, plan.driving, plan.node_x,
                           plan.tau, plan.raw, plan.hits)
    summary = _summary(args, plan, result, log_all, resumed)
    _progress(f"batlab acquire: {summary['accepted']} hits accepted, "
              f"{len(summary['rejected'])} rejected")
    if args.json:
        print(json.dumps(summary))
    return 0
