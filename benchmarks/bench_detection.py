"""Detection against what a lab would do instead: batlab vs a scale, and a scale + balance point.

    python benchmarks/bench_detection.py [--bats 6] [--diameters 0.5,0.75,1.0,1.25]
        [--lengths 3,6,9,12] [--ratio 0.3] [--kinds deep,empty,end_plug,partial,small,neutral]
        [--lab-clean 100] [--lab-bats 0] [--seed 2] [--workers 2] [--no-retest-meta]
        [--out rows.json]

Paired design on nuisance-rich virtual bats (``updating.simulate.field_fleet``, every
nuisance on): each bat is registered once (`batlab register`, its baseline) and re-tested
under the same re-test conditions (moisture, temperature, angle, accelerometer, ...) clean,
with a cork core of every size on the grid (diameter x filled length, fill ratio ``--ratio``,
behind a 1 in plug), and with one alteration of each of ``--kinds`` (random sizes); every
re-test is inspected by the real command (`batlab inspect --serial S R.uff`).

Beside batlab, on the same bats, what a lab would do without it:

- **scale**: altered when |weight - registered weight| / registered weight exceeds what
  +-2 points of moisture explain (1 %/point: 2 %) plus three scale sigmas (0.002 lb each);
- **scale + balance point**: the scale's rule, or the balance point moved by more than any
  of ``--lab-clean`` further clean nuisance-rich bats moved it (zero false alarms there).

``--lab-bats N`` adds the two lab methods on N further bats (weights and balance points only,
no FRFs, no inspection: cheap), for their rates with more bats behind them; ``--bats 0``
gives that table alone.

batlab's ROC is over its ``confidence`` (1 - p), clean re-tests against altered ones; its
operating point is its own verdict (``status`` == "altered", or ``altered`` on older
outputs). Prints the detection rate per grid cell and per kind for each method, the smallest
core found on at least 90 % of the bats, the false alarms and the ROC area.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from fleet_runner import (  # noqa: E402
    inspect_args,
    pool_map,
    run_batlab,
    save_rows,
    timed,
    verdict_row,
)

from updating.model.units import IN_TO_M  # noqa: E402
from updating.simulate.alterations import draw_alteration, end_bored  # noqa: E402
from updating.simulate.field_fleet import (  # noqa: E402
    SCALE_SIGMA_LB,
    alter_case,
    draw_case,
    write_case,
    write_retest,
)
from updating.simulate.nuisances import NUISANCES  # noqa: E402

MOISTURE_ALLOWANCE = 0.02  # +-2 points of moisture, ~1 % of weight each
METHODS = ("batlab", "scale", "scale+balance")


def retests(case, grid: list[tuple[float, float]], ratio: float, kinds: list[str],
            rng: np.random.Generator) -> list:
    """The bat's re-tests: clean, each grid core (cork), each kind (random size)."""
    L_in = case.profile.length_m / IN_TO_M
    plug = max(1.0, case.min_plug_in)
    out = [case]
    for d, length in grid:
        out.append(alter_case(case, end_bored("cork", L_in, d, length, ratio, plug), rng))
    for kind in kinds:
        out.append(alter_case(case, draw_alteration(rng, kind, L_in, case.min_plug_in), rng))
    return out


def run_bat(job: dict) -> list[dict]:
    """Register one bat, inspect all its re-tests through the registry; result rows (none,
    with the reason on stderr, when the benchmark itself fails on that bat)."""
    try:
        return bat_rows(job)
    except Exception as exc:  # the benchmark's own failure: report it, go on
        print(f"  {job['serial']}: benchmark failed: {type(exc).__name__}: {exc}",
              file=sys.stderr)
        return []


def bat_rows(job: dict) -> list[dict]:
    rng = np.random.default_rng(job["seed"])
    case = draw_case(rng, "none", NUISANCES, None, job["serial"])
    rows = []
    with tempfile.TemporaryDirectory(prefix="batlab-det-") as tmp:
        tmp = Path(tmp)
        keys = () if job["no_retest_meta"] else None
        paths = write_case(case, tmp, seed=int(rng.integers(2**31)), retest_meta_keys=keys)
        db = tmp / "registry.sqlite"
        code, _, err = run_batlab(["register", "--profile", paths["profile"], "--meta",
                                   paths["meta"], "--baseline", paths["baseline"], "--db", db,
                                   "--json"])
        if code != 0:
            raise RuntimeError(f"{job['serial']}: register failed: {err}")
        for i, rt in enumerate(retests(case, job["grid"], job["ratio"], job["kinds"], rng)):
            p = dict(paths, retest=tmp / f"retest{i}.uff")
            p["retest_meta"] = write_retest(rt, p["retest"], tmp / f"retest{i}.json",
                                            int(rng.integers(2**31)), keys)
            out, err, dt = timed(inspect_args(p, serial=job["serial"], db=db))
            rows.append(verdict_row(out, err, dt, rt.truth))
    return rows


def lab_statistics(truth: dict) -> tuple[float, float]:
    """(relative weight change, balance-point shift in) from the lab's readings."""
    r = truth["lab_readings"]
    return (abs(r["retest_lb"] - r["baseline_lb"]) / r["baseline_lb"],
            abs(r["retest_balance_in"] - r["baseline_balance_in"]))


def lab_clean_balance(n: int, seed: int) -> float:
    """The largest balance-point shift of ``n`` clean nuisance-rich bats (no FRFs needed)."""
    worst = 0.0
    for k in range(n):
        case = draw_case(np.random.default_rng(seed * 7919 + k), "none", NUISANCES)
        worst = max(worst, lab_statistics(case.truth)[1])
    return worst


def lab_verdicts(truth: dict, balance_limit_in: float) -> dict[str, bool]:
    dw, dcg = lab_statistics(truth)
    w = truth["lab_readings"]["baseline_lb"]
    scale = dw > MOISTURE_ALLOWANCE + 3 * np.sqrt(2) * SCALE_SIGMA_LB / w
    return {"scale": bool(scale), "scale+balance": bool(scale or dcg > balance_limit_in)}


def roc_auc(clean: list[float], altered: list[float]) -> float:
    """Area under the ROC: P(altered statistic > clean statistic), ties counted half."""
    if not clean or not altered:
        return float("nan")
    c, a = np.asarray(clean, float)[:, None], np.asarray(altered, float)[None, :]
    return float(np.mean((a > c) + 0.5 * (a == c)))


def reading_errors(row: dict) -> tuple[float, float, float] | None:
    """(start error in, diameter error %, fill ratio error %) of a detected alteration; None
    when batlab gave no reading. The fill error is relative to the fill ratio (an empty hole:
    absolute, in percentage points of the wood's density)."""
    t = row["truth"]
    if row["status"] != "altered" or not row.get("region_in") or \
            row.get("core_diameter_in") is None or row.get("fill_density_ratio") is None:
        return None
    r_true = t["fill_density_ratio"]
    fill = row["fill_density_ratio"] - r_true
    return (row["region_in"][0] - t["region_in"][0],
            100 * (row["core_diameter_in"] / t["core_diameter_in"] - 1),
            100 * (fill / r_true if r_true > 0 else fill))


def reading_table(altered: list[dict]) -> str:
    """Readings of the detected alterations against the targets (start within 1.5 in,
    diameter within 15 %, fill ratio within 25 %), per kind."""
    out = ["| kind | detected with a reading | start within 1.5 in | diameter within 15 % |"
           " fill within 25 % |", "|---|---|---|---|---|"]
    for kind in sorted({r["kind"] for r in altered}):
        rs = [r for r in altered if r["kind"] == kind]
        e = [x for x in (reading_errors(r) for r in rs) if x is not None]
        a = np.abs(np.array(e)) if e else np.zeros((0, 3))
        out.append(f"| {kind} | {len(e)}/{len(rs)} | {np.sum(a[:, 0] <= 1.5)} | "
                   f"{np.sum(a[:, 1] <= 15)} | {np.sum(a[:, 2] <= 25)} |")
    return "\n".join(out)


def cell_order(name: str) -> tuple:
    """Sort grid cells by diameter then length ("0.50 x 3 in" before "0.50 x 10 in"),
    other names after them alphabetically."""
    try:
        d, rest = name.split(" x ")
        return (0, float(d), float(rest.split()[0]), "")
    except ValueError:
        return (1, 0.0, 0.0, name)


def cell_name(truth: dict) -> str:
    a, b = truth["region_in"]
    return f"{truth['core_diameter_in']:.2f} x {b - a:.0f} in"


def report(rows: list[dict], balance_limit_in: float) -> str:
    """The markdown tables."""
    for r in rows:
        r["said"] = {"batlab": r["status"] == "altered", **lab_verdicts(r["truth"],
                                                                        balance_limit_in)}
    clean = [r for r in rows if r["kind"] == "none"]
    grid = [r for r in rows if r["truth"].get("grid")]
    lines = [f"clean re-tests: {len(clean)}; balance-point limit {balance_limit_in:.3f} in",
             "", "| false alarms on clean re-tests | " + " | ".join(METHODS) + " |",
             "|---|" + "---|" * len(METHODS),
             "| called altered | " + " | ".join(
                 f"{sum(r['said'][m] for r in clean)}/{len(clean)}" for m in METHODS) + " |",
             "| batlab inconclusive | " + f"{sum(r['status'] == 'inconclusive' for r in clean)}"
             f"/{len(clean)} | | |", ""]

    def rate_table(title, keyfn, subset):
        keys = sorted({keyfn(r) for r in subset}, key=cell_order)
        out = [f"| {title} | bats | " + " | ".join(METHODS) + " | batlab inconclusive |",
               "|---|---|" + "---|" * (len(METHODS) + 1)]
        found = {}
        for k in keys:
            rs = [r for r in subset if keyfn(r) == k]
            rates = {m: np.mean([r["said"][m] for r in rs]) for m in METHODS}
            found[k] = rates
            inc = sum(r["status"] == "inconclusive" for r in rs)
            out.append(f"| {k} | {len(rs)} | " + " | ".join(
                f"{100 * rates[m]:.0f} %" for m in METHODS) + f" | {inc} |")
        return out, found

    t, found = rate_table("cork core (d x filled length)", lambda r: cell_name(r["truth"]), grid)
    lines += t + [""]
    vol = {k: float(k.split(" x ")[0]) ** 2 * float(k.split(" x ")[1].split()[0]) for k in found}
    for m in METHODS:
        ok = [k for k in found if found[k][m] >= 0.9]
        best = min(ok, key=vol.get) if ok else "none on the grid"
        lines.append(f"- smallest cork core found on >= 90 % of the bats, {m}: {best}")
    others = [r for r in rows if r["kind"] != "none" and not r["truth"].get("grid")]
    if others:
        t, _ = rate_table("alteration kind", lambda r: r["kind"], others)
        lines += [""] + t
    altered = [r for r in rows if r["kind"] != "none"]
    lines += ["", reading_table(altered)]
    conf = [r["confidence"] for r in clean if r["confidence"] is not None]
    conf_alt = [r["confidence"] if r["confidence"] is not None else 0.0 for r in altered]
    lines += ["", f"- batlab ROC area over its confidence (clean vs altered re-tests): "
              f"{roc_auc(conf, conf_alt):.3f}"]
    if conf:
        top = max(conf)
        det = np.mean([c > top for c in conf_alt]) if conf_alt else float("nan")
        lines.append(f"- at zero false alarms on these clean re-tests (confidence above the "
                     f"highest clean one, 1 - {1 - top:.1e}): {100 * det:.0f} % of altered "
                     "re-tests")
    for name, idx in (("scale", 0), ("balance point", 1)):
        c = [lab_statistics(r["truth"])[idx] for r in clean]
        a = [lab_statistics(r["truth"])[idx] for r in altered]
        lines.append(f"- {name} ROC area: {roc_auc(c, a):.3f}")
    t = sorted(r["seconds"] for r in rows)
    lines.append(f"- inspect --serial time: median {t[len(t) // 2]:.1f} s, max {t[-1]:.1f} s")
    return "\n".join(lines)


def lab_only(n: int, seed: int, grid, ratio: float, kinds: list[str],
             balance_limit_in: float) -> str:
    """The lab's two methods on ``n`` further bats (readings only, no FRFs): the same grid and
    kinds, re-tested under every nuisance; a markdown table of detection rates."""
    said: dict[str, list[dict]] = {}
    for k in range(n):
        rng = np.random.default_rng(seed * 104729 + k)
        case = draw_case(rng, "none", NUISANCES)
        for rt in retests(case, grid, ratio, kinds, rng):
            t = rt.truth
            key = "clean (false alarms)" if t["kind"] == "none" else (
                cell_name(t) if t["kind"] == "cork" and (
                    t["core_diameter_in"], round(t["region_in"][1] - t["region_in"][0], 6))
                in {(d, float(length)) for d, length in grid} else t["kind"])
            said.setdefault(key, []).append(lab_verdicts(t, balance_limit_in))
    lines = [f"| re-test ({n} bats, readings only) | scale | scale+balance |", "|---|---|---|"]
    for key, vs in said.items():
        lines.append(f"| {key} | " + " | ".join(
            f"{100 * np.mean([v[m] for v in vs]):.0f} %" for m in METHODS[1:]) + " |")
    return "\n".join(lines)


def floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",") if v.strip()]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bats", type=int, default=6)
    ap.add_argument("--diameters", default="0.5,0.75,1.0,1.25", help="core diameters, in")
    ap.add_argument("--lengths", default="3,6,9,12", help="filled lengths, in")
    ap.add_argument("--ratio", type=float, default=0.3, help="cork fill density ratio")
    ap.add_argument("--kinds", default="deep,empty,end_plug,partial,small,neutral",
                    help="other alterations, one of each per bat (empty string: none)")
    ap.add_argument("--lab-clean", type=int, default=100,
                    help="clean bats (readings only) that set the balance-point limit")
    ap.add_argument("--lab-bats", type=int, default=0,
                    help="further bats for the lab's methods alone (readings only, cheap)")
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2, help="processes (at most 2)")
    ap.add_argument("--no-retest-meta", action="store_true")
    ap.add_argument("--out", default=None, help="write the result rows (JSON) here")
    args = ap.parse_args(argv)

    grid = [(d, length) for d in floats(args.diameters) for length in floats(args.lengths)]
    kinds = [k for k in args.kinds.split(",") if k]
    if args.bats == 0:  # the lab's methods alone
        limit = lab_clean_balance(args.lab_clean, args.seed)
        print(lab_only(args.lab_bats, args.seed + 1, grid, args.ratio, kinds, limit))
        return 0
    jobs = [{"serial": f"DET-{b + 1:03d}", "seed": args.seed * 100019 + b, "grid": grid,
             "ratio": args.ratio, "kinds": kinds, "no_retest_meta": args.no_retest_meta}
            for b in range(args.bats)]
    per_bat = pool_map(run_bat, jobs, args.workers, "bat")
    rows = []
    for bat_rows in per_bat:
        for i, r in enumerate(bat_rows):
            r["truth"]["grid"] = 1 <= i <= len(grid)
            rows.append(r)
    save_rows(args.out, rows)
    limit = lab_clean_balance(args.lab_clean, args.seed)
    print(f"\n## Detection ({args.bats} bats, {len(rows)} re-tests, seed {args.seed}, "
          f"retest.json {'not ' if args.no_retest_meta else ''}passed)\n")
    print(report(rows, limit))
    if args.lab_bats:
        print(f"\n### The lab's methods on {args.lab_bats} further bats\n")
        print(lab_only(args.lab_bats, args.seed + 1, grid, args.ratio, kinds, limit))
    return 0


if __name__ == "__main__":
    sys.exit(main())
