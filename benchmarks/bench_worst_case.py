"""Clean and gripped bats under wider nuisances than H0's: an ablation and a worst-case search.

Every bat is drawn by ``updating.simulate.wide`` (nuisances from families wider than the
inspection's null hypothesis, within physical bounds), written as the lab's files and
inspected through the real stateless path (``batlab.fleet.worst_case``: modal fits,
calibration, inspection). Nothing here is altered: every ``altered`` is a false alarm.

    # each wide nuisance alone on clean bats, none, and all together: F quantiles per group
    OPENBLAS_NUM_THREADS=1 nice -n 10 python benchmarks/bench_worst_case.py ablation \
        --bats 12 --out ablation.jsonl
    # per bat, search the nuisances for the largest F (random starts, then a (1+1)-ES)
    OPENBLAS_NUM_THREADS=1 nice -n 10 python benchmarks/bench_worst_case.py search \
        --bats 6 --budget 25 --starts 10 --offset 100 --out search.jsonl
    # the band-edge constructor's bats (issue 36: the other plane's mode last, a legal grip)
    OPENBLAS_NUM_THREADS=1 nice -n 10 python benchmarks/bench_worst_case.py band_edge \
        --bats 12 --out band_edge.jsonl
    # the tables again from saved rows
    python benchmarks/bench_worst_case.py summary ablation.jsonl search.jsonl

Seeds: ``--purpose development`` (default; 100000-199999, ``--offset`` into the range) may
be looked at and tuned on; ``--purpose validation`` (900000-999999) is for measuring a method
that is fixed, never for tuning it. ``--groups`` picks the ablation's groups (a nuisance, or
several joined by +, "none", "all"; default: none, each alone, all); "all" gives each bat its
handle in turn (bare, legal grip, bare, legal grip, bare, tar past 18 in), as ``search``
does. ``--cache DIR`` keeps the modal fits and calibration of each bat and vector, so a run
after a change of the inspection alone re-scores in about a third of the time.
``--no-retest-meta`` inspects without retest.json; ``--coherence`` gives the tests' files
their coherence (5 hits a point: the noise measured, docs/noise.md); ``--records N`` gives the
search's bats the lab's records of their wood and rooms (both tests' dates, rooms and N
moisture readings a station, made from each searched bat's own moisture). Rows (JSON lines) go to
``--out`` (the search's also to ``<out>.log`` as they are made), tables to stdout, progress
to stderr.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from batlab.fleet.runner import fleet_map  # noqa: E402
from batlab.fleet.worst_case import ablation_row, band_edge_row, search_bat  # noqa: E402
from updating.simulate import wide  # noqa: E402
from updating.simulate.worst_case import quantile_table, worst_table  # noqa: E402


def group_nuisances(group: str, index: int) -> tuple[str, ...]:
    """Return an ablation group's nuisances for its ``index``-th bat."""
    if group == "none":
        return ()
    if group == "all":
        return wide.fleet_nuisances(index)
    return tuple(group.split("+"))


def ablation_jobs(args) -> list[dict]:
    groups = args.groups.split(",") if args.groups else ["none", *wide.WIDE_NUISANCES, "all"]
    seeds = wide.fleet_seeds(args.bats, args.purpose, args.offset)
    return [{"group": g, "seed": s, "nuisances": group_nuisances(g, i),
             "with_meta": not args.no_retest_meta, "coherence": args.coherence,
             "cache": args.cache}
            for g in groups for i, s in enumerate(seeds)]


def search_jobs(args) -> list[dict]:
    seeds = wide.fleet_seeds(args.bats, args.purpose, args.offset)
    log = None if args.out is None else f"{args.out}.log"
    return [{"seed": s, "handle": wide.HANDLES[i % len(wide.HANDLES)],
             "nuisances": wide.fleet_nuisances(i), "budget": args.budget,
             "starts": args.starts, "with_meta": not args.no_retest_meta,
             "coherence": args.coherence, "records": args.records,
             "cache": args.cache, "log": log} for i, s in enumerate(seeds)]


def write_rows(path, rows: list[dict]) -> None:
    if path:
        Path(path).write_text("".join(json.dumps(r, default=float) + "\n" for r in rows))


def print_tables(ablation: list[dict], searched: list[dict]) -> None:
    if ablation:
        print("\n## Clean F per group of wide nuisances\n")
        print(quantile_table(ablation))
    if searched:
        print("\n## Worst cases (searched per bat)\n")
        print(worst_table(searched))
        for b in searched:
            ev = [e for e in b["evaluations"] if e.get("F") is not None]
            bad = [e for e in b["evaluations"] if e["status"] in ("altered", "inconclusive")]
            top = [max(ev, key=lambda e: e["F"])] if ev else []
            for e in top + [e for e in bad if e not in top]:
                F = "-" if e.get("F") is None else f"{e['F']:.3g}"
                print(f"\n- bat {b['seed']} ({b['handle']}) evaluation {e['index']} "
                      f"({e['phase']}): F {F}, {e['status']}: "
                      f"{(e.get('reasons') or [''])[0]}\n"
                      f"  {wide.describe(e.get('settings') or {}, e.get('made'))}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("action", choices=("ablation", "band_edge", "search", "summary"))
    ap.add_argument("files", nargs="*", help="summary: JSON-lines files of earlier runs")
    ap.add_argument("--bats", type=int, default=4)
    ap.add_argument("--purpose", choices=("development", "validation"), default="development")
    ap.add_argument("--offset", type=int, default=0, help="first seed's place in the range")
    ap.add_argument("--groups", default=None, help="ablation: comma-separated groups")
    ap.add_argument("--budget", type=int, default=25, help="search: evaluations per bat")
    ap.add_argument("--starts", type=int, default=10, help="search: random starts per bat")
    ap.add_argument("--workers", type=int, default=1, help="local Dask worker processes")
    ap.add_argument("--scheduler", default=None, help="a running Dask scheduler's address")
    ap.add_argument("--cache", default=None, help="keep the fits of every bat and vector here")
    ap.add_argument("--no-retest-meta", action="store_true")
    ap.add_argument("--coherence", action="store_true",
                    help="the tests' files carry their coherence: the noise measured "
                         "(docs/noise.md)")
    ap.add_argument("--records", type=int, default=None, metavar="N",
                    help="search: the lab's records of each bat's wood and rooms (dates, "
                         "rooms, N moisture readings a station; docs/noise.md)")
    ap.add_argument("--out", default=None, help="JSON lines of the rows")
    args = ap.parse_args(argv)
    if args.purpose == "validation":
        print("validation seeds: for measuring a fixed method, never for tuning it",
              file=sys.stderr)
    if args.action == "summary":
        rows = [json.loads(s) for f in args.files for s in Path(f).read_text().splitlines()
                if s]
        print_tables([r for r in rows if "group" in r], [r for r in rows if "evaluations" in r])
        return 0
    if args.action in ("ablation", "band_edge"):
        if args.action == "ablation":
            fn, jobs = ablation_row, ablation_jobs(args)
        else:
            fn, jobs = band_edge_row, [
                {"seed": s, "with_meta": not args.no_retest_meta, "coherence": args.coherence,
                 "cache": args.cache}
                for s in wide.fleet_seeds(args.bats, args.purpose, args.offset)]
        rows = fleet_map(fn, jobs, args.workers, "bat", args.scheduler)
        write_rows(args.out, rows)
        print_tables(rows, [])
    else:
        rows = fleet_map(search_bat, search_jobs(args), args.workers, "bat", args.scheduler)
        write_rows(args.out, rows)
        print_tables([], rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
