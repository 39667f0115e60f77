"""Detection against what a lab would do instead: batlab vs a scale, and a scale + balance point.

    python benchmarks/bench_detection.py [--bats 6] [--diameters 0.5,0.75,1.0,1.25]
        [--lengths 3,6,9,12] [--ratio 0.3] [--kinds deep,empty,end_plug,partial,small,neutral]
        [--lab-clean 100] [--lab-bats 0] [--seed 2] [--workers 2] [--scheduler ADDR]
        [--no-retest-meta] [--coherence] [--records N]
        [--out rows.json]

Paired design on nuisance-rich virtual bats (``updating.simulate.field_fleet``, every
nuisance on): each bat is registered once (`batlab register`, its baseline) and re-tested
under the same re-test conditions (moisture, temperature, angle, accelerometer, ...) clean,
with a cork core of every size on the grid (diameter x filled length, fill ratio ``--ratio``,
behind a 1 in plug), and with one alteration of each of ``--kinds`` (random sizes); every
re-test is inspected by the real command (`batlab inspect --serial S R.uff`).

Beside batlab, on the same bats, what a lab would do without it
(``updating.simulate.lab_methods``; the report: ``updating.simulate.detection``, the runner:
``batlab.fleet``):

- **scale**: altered when |weight - registered weight| / registered weight exceeds what
  +-2 points of moisture explain (1 %/point: 2 %) plus three scale sigmas (0.002 lb each);
- **scale + balance point**: the scale's rule, or the balance point moved by more than any
  of ``--lab-clean`` further clean nuisance-rich bats moved it (zero false alarms there).

``--lab-bats N`` adds the two lab methods on N further bats (weights and balance points only,
no FRFs, no inspection: cheap), for their rates with more bats behind them; ``--bats 0``
gives that table alone.

batlab's ROC is over its ``confidence`` (1 - p), clean re-tests against altered ones; its
operating point is its own verdict (``status`` == "altered", or ``altered`` on older
outputs), its screen "altered" or "inconclusive" (the bat goes to the X-ray). Prints the
detection rate per grid cell and per kind for each method, the volume from which 90 % of the
cores are found (a logistic fit in log volume) and the smallest cell found on at least 90 %
of the bats, the false alarms and the ROC area. ``--records N`` adds the lab's records of the
wood and the room (dates, rooms, N moisture readings a station) to both tests' files.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # small matrices: threads only contend
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from batlab.fleet.jobs import detection_jobs, detection_rows  # noqa: E402
from batlab.fleet.runner import fleet_map, save_rows  # noqa: E402
from updating.simulate.detection import detection_report, lab_only_report  # noqa: E402
from updating.simulate.lab_methods import clean_balance_limit_in  # noqa: E402


def floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",") if v.strip()]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bats", type=int, default=6)
    ap.add_argument("--diameters", default="0.35,0.5,0.75,1.0,1.25",
                    help="core diameters, in (0.35 x 3 in: 0.29 in^3)")
    ap.add_argument("--lengths", default="3,6,9,12", help="filled lengths, in")
    ap.add_argument("--ratio", type=float, default=0.3, help="cork fill density ratio")
    ap.add_argument("--kinds", default="deep,empty,end_plug,partial,small,neutral",
                    help="other alterations, one of each per bat (empty string: none)")
    ap.add_argument("--lab-clean", type=int, default=100,
                    help="clean bats (readings only) that set the balance-point limit")
    ap.add_argument("--lab-bats", type=int, default=0,
                    help="further bats for the lab's methods alone (readings only, cheap)")
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--workers", type=int, default=None,
                    help="local Dask worker processes (default: one per core)")
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="a running Dask scheduler (tcp://HOST:PORT) instead of a local cluster")
    ap.add_argument("--no-retest-meta", action="store_true")
    ap.add_argument("--coherence", action="store_true",
                    help="the tests' files carry their coherence (5 hits a point): the "
                         "noise measured (docs/noise.md)")
    ap.add_argument("--records", type=int, default=None, metavar="N",
                    help="the lab's records of the wood and the room in meta.json and "
                         "retest.json: both tests' dates, rooms and N moisture readings a "
                         "station (0: dates and rooms alone; docs/noise.md)")
    ap.add_argument("--out", default=None, help="write the result rows (JSON) here")
    args = ap.parse_args(argv)

    grid = [(d, length) for d in floats(args.diameters) for length in floats(args.lengths)]
    kinds = [k for k in args.kinds.split(",") if k]
    if args.bats == 0:  # the lab's methods alone
        limit = clean_balance_limit_in(args.lab_clean, args.seed)
        print(lab_only_report(args.lab_bats, args.seed + 1, grid, args.ratio, kinds, limit))
        return 0
    jobs = detection_jobs(args.bats, args.seed, grid, args.ratio, kinds, args.no_retest_meta,
                          args.coherence, args.records)
    rows = [r for bat in fleet_map(detection_rows, jobs, args.workers, "bat", args.scheduler)
            for r in bat]
    save_rows(args.out, rows)
    limit = clean_balance_limit_in(args.lab_clean, args.seed)
    print(f"\n## Detection ({args.bats} bats, {len(rows)} re-tests, seed {args.seed}, "
          f"retest.json {'not ' if args.no_retest_meta else ''}passed"
          + ("" if args.records is None else f", {args.records} moisture readings a station")
          + ")\n")
    print(detection_report(rows, limit))
    if args.lab_bats:
        print(f"\n### The lab's methods on {args.lab_bats} further bats\n")
        print(lab_only_report(args.lab_bats, args.seed + 1, grid, args.ratio, kinds, limit))
    return 0


if __name__ == "__main__":
    sys.exit(main())
