"""What the bending pairs' splits read of a flat (issue 38), on the project's field bats.

Each bat is a nuisance-rich field bat with both planes' pairs resolved
(``updating.simulate.plane_pairs.planes_case``: tapped 30-60 deg, each plane's E/G moved by
up to 3 % between the tests, a reference with calibration error, each member's frequency
with 3e-5 relative noise unless ``--noise``). Flats: depth as tabled, 4-14 in long ending
0.5-2 in from the barrel end, normal at any angle to the grain planes (the rulebook's).
Printed (markdown):

- per depth: bats, flats read (p < 1e-3 family-wise), of those with the normal within 25 deg
  of a grain plane (|cos 2 phi| >= 0.64), the normal's side right, localised, of the
  localised the region's centre within 1.5 in, and the depth read (the depth with the
  normal in a grain plane, a lower bound) no deeper than the flat by two sd;
- clean bats (none, pine tar, grip tape, spray), on the seeds the tests use and on a
  validation fleet never tuned on: bats, flats read (false alarms), the largest statistic
  against the critical value;
- the reader's mean time per bat.

    python benchmarks/bench_plane_split.py --bats 10 --clean 20 --seed 1
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from updating.inspect.plane_split import read_plane_split  # noqa: E402
from updating.model.local_change import LocalChange  # noqa: E402
from updating.model.units import IN_TO_M  # noqa: E402
from updating.simulate.field_fleet import draw_case  # noqa: E402
from updating.simulate.plane_pairs import planes_case  # noqa: E402

DEPTHS_IN = (0.02, 0.03, 0.05, 0.075, 0.1)
CLEAN_KINDS = ("none", "pine_tar", "grip_tape", "spray")


def _flat(rng: np.random.Generator, length_in: float, depth_in: float) -> LocalChange:
    x1 = length_in - rng.uniform(0.5, 2.0)
    x0 = x1 - rng.uniform(4.0, 14.0)
    return LocalChange(x0 * IN_TO_M, x1 * IN_TO_M, flat_depth_m=depth_in * IN_TO_M,
                       flat_angle_deg=rng.uniform(0.0, 180.0))


def _read(seed: int, kind: str, flat: LocalChange | None, noise: float):
    c = planes_case(seed, kind, flat, noise)
    t = time.perf_counter()
    s = read_plane_split(c.case.profile, c.reference, c.baseline, c.retest)
    return s, time.perf_counter() - t


def flats(n: int, seed: int, noise: float, times: list) -> list[str]:
    rows = ["| depth in | bats | read | near a grain plane | of those read | side right "
            "| localised | centre within 1.5 in | depth read - 2 sd <= depth |",
            "|---|---|---|---|---|---|---|---|---|"]
    rng = np.random.default_rng(seed)
    for depth in DEPTHS_IN:
        read = near = near_read = side = loc = within = bound = 0
        for i in range(n):
            s_case = seed * 10000 + int(1000 * depth) * 10 + i
            length_in = draw_case(np.random.default_rng(s_case)).profile.length_m / IN_TO_M
            flat = _flat(rng, length_in, depth)
            s, dt = _read(s_case, "none", flat, noise)
            times.append(dt)
            cos2 = np.cos(np.radians(2 * flat.flat_angle_deg))
            read += s.significant
            if abs(cos2) >= 0.64:
                near += 1
                near_read += s.significant
            if s.significant:
                side += s.nearer_plane == ("upper" if cos2 > 0 else "lower")
                bound += s.depth_m - 2 * s.depth_sd_m <= flat.flat_depth_m
                if s.localised:
                    loc += 1
                    within += abs(s.centre_m - 0.5 * (flat.x0_m + flat.x1_m)) <= 1.5 * IN_TO_M
            print(f"depth {depth} bat {i + 1}/{n}", file=sys.stderr)
        rows.append(f"| {depth} | {n} | {read} | {near} | {near_read} | {side}/{read} | "
                    f"{loc}/{read} | {within}/{loc} | {bound}/{read} |")
    return rows


def clean(n: int, seeds: range, label: str, noise: float, times: list) -> str:
    stats, alarms, crit = [], 0, float("nan")
    for i, seed in zip(range(n), seeds, strict=False):
        s, dt = _read(seed, CLEAN_KINDS[i % len(CLEAN_KINDS)], None, noise)
        times.append(dt)
        stats.append(s.statistic)
        alarms += s.significant
        crit = s.critical
        print(f"{label} bat {i + 1}/{n}", file=sys.stderr)
    return (f"| {label} | {n} | {alarms} | {np.nanmax(stats):.1f} | "
            f"{np.nanmedian(stats):.1f} | {crit:.1f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bats", type=int, default=10, help="flattened bats per depth")
    ap.add_argument("--clean", type=int, default=20, help="clean bats per fleet")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--noise", type=float, default=3e-5,
                    help="each member's relative frequency sd")
    args = ap.parse_args()
    times: list[float] = []
    t0 = time.perf_counter()
    rows = flats(args.bats, args.seed, args.noise, times)
    clean_rows = ["| clean fleet | bats | flats read | largest Delta chi^2 | median | critical |",
                  "|---|---|---|---|---|---|",
                  clean(args.clean, range(10, 10 + args.clean), "the tests' seeds (10-)",
                        args.noise, times),
                  clean(args.clean, range(50000 + args.seed * 1000, 60000),
                        "validation (never tuned on)", args.noise, times)]
    print(f"member frequency noise {args.noise:g} (relative sd)\n")
    print("\n".join(rows))
    print()
    print("\n".join(clean_rows))
    print(f"\nreader: {1e3 * np.mean(times):.0f} ms per bat (mean of {len(times)}); "
          f"benchmark {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
