"""False alarms on a nuisance-rich virtual fleet of unaltered bats, through `batlab inspect`.

    python benchmarks/bench_false_alarm.py [--n 40] [--alone 3] [--integrity 2] [--seed 1]
                                           [--workers 2] [--no-retest-meta] [--out rows.json]

Groups of unaltered bats (``updating.simulate.field_fleet.draw_case``), each bat's files
written as a lab hands them over and inspected statelessly by the real command
(``fleet_runner``):

- ``all nuisances`` (``--n`` bats): every nuisance at once (end-grain moisture, temperature,
  billet gradients, two bending planes, cupped end, 1-2 % noise, 8-20 points, 2 kHz band on
  half, replaced or re-mounted accelerometer, re-hung bungees);
- ``alone: X`` (``--alone`` bats each): nuisance X alone, for every nuisance and a uniform
  1.5-2 point moisture drift;
- ``integrity: X`` (``--integrity`` bats each): a data-integrity slip (receptance labelled
  accelerance, g/N labelled SI, another bat's re-test, no point on the barrel) among all
  nuisances; the right answer is "inconclusive" or a refusal, never "altered".

Prints the count of not_altered / inconclusive / altered / refused per group and checks:
no clean bat called altered, at most 5 % inconclusive in ``all nuisances``, no integrity case
called altered. Exit 1 when a clean or integrity bat is called altered.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from fleet_runner import (  # noqa: E402
    count_table,
    inspect_args,
    pool_map,
    save_rows,
    timed,
    verdict_row,
)

from updating.simulate.field_fleet import draw_case, write_case  # noqa: E402
from updating.simulate.integrity import INTEGRITY  # noqa: E402
from updating.simulate.nuisances import NUISANCES, OPTIONAL_NUISANCES  # noqa: E402


def plan(n_all: int, n_alone: int, n_integrity: int, seed: int) -> list[dict]:
    """The bats to inspect: group, serial, seed, nuisances, integrity slip."""
    jobs = []

    def add(group, nuisances, integrity, count):
        for _ in range(count):
            k = len(jobs)
            jobs.append({"group": group, "serial": f"FA-{k + 1:04d}", "seed": seed * 100003 + k,
                         "nuisances": tuple(nuisances), "integrity": integrity})

    add("all nuisances", NUISANCES, None, n_all)
    for name in NUISANCES + OPTIONAL_NUISANCES:
        add(f"alone: {name}", (name,), None, n_alone)
    for integ in INTEGRITY:
        add(f"integrity: {integ}", NUISANCES, integ, n_integrity)
    return jobs


def run_job(job: dict, retest_meta: bool = True) -> dict:
    """Draw, write and inspect one bat; its result row (with the job's group). A failure of
    the simulation is an "error" row, not the end of the run."""
    try:
        return inspect_job(job, retest_meta)
    except Exception as exc:  # the benchmark's own failure: report it, go on
        truth = {"serial": job["serial"], "kind": "none", "integrity": job["integrity"],
                 "expected": "inconclusive" if job["integrity"] else "not_altered"}
        row = verdict_row(None, f"{type(exc).__name__}: {exc}", 0.0, truth)
        row.update(status="error", group=job["group"])
        return row


def inspect_job(job: dict, retest_meta: bool) -> dict:
    rng = np.random.default_rng(job["seed"])
    case = draw_case(rng, "none", job["nuisances"], job["integrity"], job["serial"])
    with tempfile.TemporaryDirectory(prefix="batlab-fa-") as tmp:
        paths = write_case(case, tmp, seed=int(rng.integers(2**31)),
                           retest_meta_keys=None if retest_meta else ())
        out, err, dt = timed(inspect_args(paths))
    row = verdict_row(out, err, dt, case.truth)
    row["group"] = job["group"]
    return row


def run_job_without_meta(job: dict) -> dict:
    return run_job(job, retest_meta=False)


def summarise(rows: list[dict]) -> tuple[str, list[tuple[str, bool]]]:
    """The count table and the checks (text, passed)."""
    groups: dict[str, list[dict]] = {}
    for r in rows:
        groups.setdefault(r["group"], []).append(r)
    clean = [r for r in rows if r["integrity"] is None]
    slips = [r for r in rows if r["integrity"] is not None]
    every = groups.get("all nuisances", [])
    fa = sum(r["status"] == "altered" for r in clean)
    inc = sum(r["status"] == "inconclusive" for r in every)
    checks = [(f"clean bats called altered: {fa}/{len(clean)} (0)", fa == 0)]
    errors = sum(r["status"] == "error" for r in rows)
    if errors:
        checks.append((f"bats the benchmark itself failed on: {errors}", False))
    if every:
        checks.append((f"inconclusive among all-nuisance bats: {inc}/{len(every)} "
                       f"({100 * inc / len(every):.0f} %, <= 5 %)", inc <= 0.05 * len(every)))
    if slips:
        bad = sum(r["status"] == "altered" for r in slips)
        checks.append((f"integrity cases called altered: {bad}/{len(slips)} (0)", bad == 0))
    t = sorted(r["seconds"] for r in rows)
    if t:
        checks.append((f"inspect time (stateless, calibration included): median "
                       f"{t[len(t) // 2]:.1f} s, max {t[-1]:.1f} s", True))
    return count_table(groups), checks


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=40, help="all-nuisance clean bats (default 40)")
    ap.add_argument("--alone", type=int, default=3, help="bats per nuisance alone (default 3)")
    ap.add_argument("--integrity", type=int, default=2,
                    help="bats per data-integrity slip (default 2)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", type=int, default=2, help="processes (at most 2)")
    ap.add_argument("--no-retest-meta", action="store_true",
                    help="do not pass retest.json (weight, accelerometer mass, temperature)")
    ap.add_argument("--out", default=None, help="write the result rows (JSON) here")
    args = ap.parse_args(argv)

    jobs = plan(args.n, args.alone, args.integrity, args.seed)
    fn = run_job_without_meta if args.no_retest_meta else run_job
    rows = pool_map(fn, jobs, args.workers, "bat")
    save_rows(args.out, rows)
    table, checks = summarise(rows)
    print(f"\n## False alarms ({len(rows)} bats, seed {args.seed}, retest.json "
          f"{'not ' if args.no_retest_meta else ''}passed)\n")
    print(table)
    print()
    for text, ok in checks:
        print(f"  {'PASS' if ok else 'FAIL'}  {text}")
    return 0 if all(ok for text, ok in checks if "called altered" in text) else 1


if __name__ == "__main__":
    sys.exit(main())
