"""False alarms on a nuisance-rich virtual fleet of unaltered bats, through `batlab inspect`.

    python benchmarks/bench_false_alarm.py [--n 40] [--alone 3] [--integrity 2] [--seed 1]
                                           [--workers 2] [--scheduler ADDR] [--no-retest-meta]
                                           [--out rows.json]

Groups of unaltered bats (``updating.simulate.field_fleet.draw_case``), each bat's files
written as a lab hands them over and inspected statelessly by the real command
(``batlab.fleet``; scored by ``updating.simulate.scoring``):

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

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # small matrices: threads only contend
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from batlab.fleet.jobs import false_alarm_row, false_alarm_row_without_meta  # noqa: E402
from batlab.fleet.runner import fleet_map, save_rows  # noqa: E402
from updating.simulate.scoring import false_alarm_plan, false_alarm_summary  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=40, help="all-nuisance clean bats (default 40)")
    ap.add_argument("--alone", type=int, default=3, help="bats per nuisance alone (default 3)")
    ap.add_argument("--integrity", type=int, default=2,
                    help="bats per data-integrity slip (default 2)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", type=int, default=None,
                    help="local Dask worker processes (default: one per core)")
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="a running Dask scheduler (tcp://HOST:PORT) instead of a local cluster")
    ap.add_argument("--no-retest-meta", action="store_true",
                    help="do not pass retest.json (weight, accelerometer mass, temperature)")
    ap.add_argument("--out", default=None, help="write the result rows (JSON) here")
    args = ap.parse_args(argv)

    jobs = false_alarm_plan(args.n, args.alone, args.integrity, args.seed)
    fn = false_alarm_row_without_meta if args.no_retest_meta else false_alarm_row
    rows = fleet_map(fn, jobs, args.workers, "bat", args.scheduler)
    save_rows(args.out, rows)
    table, checks = false_alarm_summary(rows)
    print(f"\n## False alarms ({len(rows)} bats, seed {args.seed}, retest.json "
          f"{'not ' if args.no_retest_meta else ''}passed)\n")
    print(table)
    print()
    for text, ok in checks:
        print(f"  {'PASS' if ok else 'FAIL'}  {text}")
    return 0 if all(ok for text, ok in checks if "called altered" in text) else 1


if __name__ == "__main__":
    sys.exit(main())
