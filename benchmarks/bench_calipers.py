"""What the re-test's caliper profile finds alone (issue 38), on the project's field bats.

For each kind (flattened, shaved, grooved, clean, pine tar) N bats are drawn
(``updating.simulate.field_fleet.draw_case``, every nuisance, the rulebook's change at
random), their re-test read by the virtual calipers (``updating.simulate.calipers``: 0.002 in
noise, 0.001-0.004 in of ovality, the caliper set within 0.02 in of the station) at K
orientations, and compared with the lab's registered profile
(``updating.inspect.calipers.compare_profiles``; no modal test). Printed (markdown):

- per kind: bats, found, the right kind read, region start within 1.5 in, false alarms;
- flats and grooves: how many the survey shows -- a reading the change shortens by more
  than three caliper sigmas (``shown_loss_in``: the same survey, placement, ovality and
  noise, of the bat without its change, less this one's) -- and how many of those were
  found, the misses (their largest loss and statistic);
- the depth of a flat facing an orientation found on 90 % of the bats, 4 and 10 in long;
- the null alone: M clean surveys with the registration read four ways (its mean diameter,
  one orientation, a random one at every station, the mean of four), their largest
  statistic against the bound.

    python benchmarks/bench_calipers.py --bats 200 --null 2000 --orientations 4 --seed 1
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from updating.inspect.calipers import compare_profiles  # noqa: E402
from updating.model.local_change import LocalChange  # noqa: E402
from updating.model.profile import Profile  # noqa: E402
from updating.model.units import IN_TO_M  # noqa: E402
from updating.simulate.calipers import (  # noqa: E402
    draw_ovality,
    orientations_deg,
    read_bat,
    retest_survey,
)
from updating.simulate.field_fleet import draw_case  # noqa: E402
from updating.simulate.fleet import pro_profile  # noqa: E402

KINDS = ("flattened", "shaved", "grooved", "none", "pine_tar")
EXPECT = {"flattened": ("flat", "shaved"), "shaved": ("shaved",), "grooved": ("grooves",)}
SIGMA_IN = 0.002


def shown_loss_in(seed: int, bat, k: int, mark_deg: float) -> float:
    """The largest loss the bat's change makes in one reading of its survey, in.

    The survey of ``bat`` (``retest_survey`` with the random source of ``seed``) less the
    same survey of the bat without its changes: the same placements, ovality and noise, so
    the difference is what the change took from each reading as the caliper was set.
    """
    changed, _ = retest_survey(np.random.default_rng([seed, 38]), bat, k, mark_deg=mark_deg)
    clean, _ = retest_survey(np.random.default_rng([seed, 38]), replace(bat, local_changes=()),
                             k, mark_deg=mark_deg)
    return float(np.max(clean.diameter_m - changed.diameter_m)) / IN_TO_M


def bats(kind: str, n: int, k: int, seed: int) -> dict:
    """Run ``n`` bats of ``kind`` through the survey's comparison; counts and misses."""
    out = {"bats": 0, "found": 0, "kind_right": 0, "start_within": 0, "shows": 0,
           "shows_found": 0, "misses": [], "seconds": 0.0}
    for s in range(seed, seed + n):
        case = draw_case(np.random.default_rng(s), kind)
        mark = case.baseline.theta_deg
        survey, _ = retest_survey(np.random.default_rng([s, 38]), case.retest, k,
                                  mark_deg=mark)
        t0 = time.perf_counter()
        result = compare_profiles(case.profile, survey, case.baseline.material.rho_kg_m3)
        out["seconds"] += time.perf_counter() - t0
        out["bats"] += 1
        found = bool(result.changes)
        out["found"] += found
        loss = shown_loss_in(s, case.retest, k, mark) if kind in EXPECT else 0.0
        shows = loss > 3 * SIGMA_IN
        out["shows"] += shows
        out["shows_found"] += shows and found
        if shows and not found:
            out["misses"].append((s, round(loss, 4), round(result.statistic, 2),
                                  round(result.critical, 2)))
        if found and kind in EXPECT:
            c = max(result.changes, key=lambda c: c.statistic)
            out["kind_right"] += c.kind in EXPECT[kind]
            start = min(c.region_m[0] for c in result.changes) / IN_TO_M
            out["start_within"] += abs(start - case.truth["region_in"][0]) <= 1.5
    return out


def smallest_flat(span_in: float, k: int, n: int, seed: int) -> tuple[float | None, list]:
    """The depth of a flat facing an orientation found on 90 % of ``n`` bats, in."""
    rows = []
    for depth in (0.004, 0.005, 0.006, 0.007, 0.008, 0.01, 0.012, 0.015, 0.02, 0.03):
        hits = 0
        for s in range(seed, seed + n):
            case = draw_case(np.random.default_rng(s), "none")
            L = case.retest.profile.length_m
            rng = np.random.default_rng([s, 39])
            facing = orientations_deg(k)[rng.integers(k)] + case.baseline.theta_deg
            flat = LocalChange(L - (span_in + 1) * IN_TO_M, L - IN_TO_M,
                               flat_depth_m=depth * IN_TO_M, flat_angle_deg=facing)
            bat = replace(case.retest, local_changes=(flat,))
            survey, _ = retest_survey(rng, bat, k, mark_deg=case.baseline.theta_deg)
            hits += bool(compare_profiles(case.profile, survey, 650.0).changes)
        rows.append((depth, hits))
    found = [d for d, h in rows if h >= 0.9 * n]
    return (min(found) if found else None), rows


def null(m: int, k: int, seed: int) -> dict:
    """Clean surveys with the registration read four ways: false alarms, largest z."""
    out = {}
    for how in ("mean", "one_orientation", "any_orientation", "averaged"):
        z, alarms, crit = [], 0, []
        for s in range(seed, seed + m):
            rng = np.random.default_rng([s, 40])
            truth = pro_profile(rng)
            ov = draw_ovality(rng)
            x, d = truth.x_m, truth.diameter_m
            if how == "mean":
                reg = Profile(x, d + 0.003 * IN_TO_M * rng.standard_normal(x.size))
            elif how == "averaged":
                reg = read_bat(rng, truth, (), np.unique(x), orientations_deg(4), ov).mean_profile()
            else:
                angle = (np.full(x.size, rng.uniform(0, 180)) if how == "one_orientation"
                         else rng.uniform(0, 180, x.size))
                reg = Profile(x, d + ov.width_m(x, d, truth.length_m, angle)
                              + 0.002 * IN_TO_M * rng.standard_normal(x.size))
            survey = read_bat(rng, truth, (), np.unique(x), orientations_deg(k), ov)
            r = compare_profiles(reg, survey, 650.0)
            z.append(r.statistic)
            alarms += bool(r.changes)
            crit.append(r.critical)
        out[how] = {"surveys": m, "false_alarms": alarms, "z_max": float(np.max(z)),
                    "z_99": float(np.quantile(z, 0.99)), "bound": (min(crit), max(crit)),
                    "margin": float(np.min(np.array(crit) - np.array(z)))}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bats", type=int, default=100, help="bats per kind")
    ap.add_argument("--null", type=int, default=500, help="clean surveys per registration")
    ap.add_argument("--orientations", type=int, default=4)
    ap.add_argument("--limit-bats", type=int, default=40,
                    help="bats per depth for the smallest flat")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--null-seed", type=int, default=None,
                    help="the clean surveys' first seed (default: --seed)")
    args = ap.parse_args(argv)
    k = args.orientations
    print(f"## Calipers alone: {args.bats} field bats a kind, {k} orientations, seed "
          f"{args.seed}\n")
    print("| kind | bats | found | kind right | start within 1.5 in | the survey shows "
          "| of those found | s a survey |")
    print("|---|---|---|---|---|---|---|---|")
    misses = {}
    for i, kind in enumerate(KINDS):
        r = bats(kind, args.bats, k, args.seed + 10000 * i)
        shows = "a reading short by > 3 sigma" if kind in EXPECT else ""
        alarm = "" if kind in EXPECT else " (false alarms)"
        print(f"| {kind} | {r['bats']} | {r['found']}{alarm} | {r['kind_right']} | "
              f"{r['start_within']} | {r['shows'] if kind in EXPECT else '-'} {shows} | "
              f"{r['shows_found'] if kind in EXPECT else '-'} | "
              f"{r['seconds'] / max(r['bats'], 1):.3f} |")
        misses[kind] = r["misses"]
    for kind, m in misses.items():
        if m:
            print(f"\n{kind}: shown but missed (seed, largest loss in, z, bound): {m}")
    print("\n| flat facing an orientation | found on 90 % from | found / bats by depth (in) |")
    print("|---|---|---|")
    for span in (4.0, 10.0) if args.limit_bats else ():
        depth, rows = smallest_flat(span, k, args.limit_bats, args.seed)
        print(f"| {span:g} in long | {depth if depth is not None else '-'} in | "
              + ", ".join(f"{d:g}: {h}" for d, h in rows) + " |")
    if not args.null:
        return 0
    null_seed = args.seed if args.null_seed is None else args.null_seed
    print(f"\nclean surveys from seed {null_seed}:\n")
    print("| registration read as | clean surveys | called changed | largest z | 99 % z "
          "| bound (range) | smallest bound - z |")
    print("|---|---|---|---|---|---|---|")
    for how, r in null(args.null, k, null_seed).items():
        print(f"| {how} | {r['surveys']} | {r['false_alarms']} | {r['z_max']:.2f} | "
              f"{r['z_99']:.2f} | {r['bound'][0]:.2f}-{r['bound'][1]:.2f} | "
              f"{r['margin']:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
