"""What the inspection makes of every change the rulebook names, and of the legal grips.

For each kind (clean bats, the legal grips, pine tar past 18 in, nails, shaved, flattened
and grooved barrels, wax coats, and core kinds of ``updating.simulate.alterations``), N
realistic bats (``updating.simulate.field_fleet.draw_case``, every nuisance at random) are
written as the lab's files and inspected through the real command in a Dask worker
(``batlab inspect ... --json``, ``batlab.fleet.runner``), with retest.json and,
for the first ``--without`` of them, the same bats without it; for the first
``--with-profile`` of them, the same bats again with retest.json and the re-test's caliper
profile (``updating.simulate.calipers``: four orientations, 0.002 in noise, 0.001-0.004 in
of ovality; ``--retest-profile``). One JSON line per bat on
stdout (kind, truth, status, reasons, region_in, finding, time); progress and a table per
kind on stderr: altered / not_altered / inconclusive, the region's start within 1.5 in of
the truth's (of the altered bats called altered), the right ``finding.kind`` (when the
output has a finding).

    nice python benchmarks/bench_rulebook.py --per-kind 6 --without 3 --with-profile 6 \
        --workers 2 > rulebook.jsonl

``--summary FILE`` re-summarises a run. After the table, the detection limits per kind
(``updating.simulate.limits.limits_table``): the smallest change found on 90 % of the bats,
with and without retest.json and with the re-test profile, beside a scale and a scale with
the balance point (its limit from ``--balance-clean`` clean bats) judged on the same bats;
false alarms for clean kinds.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from batlab.fleet.runner import fleet_map, inspect_args, timed  # noqa: E402
from updating.simulate.field_fleet import draw_case, write_case  # noqa: E402
from updating.simulate.lab_methods import clean_balance_limit_in  # noqa: E402
from updating.simulate.limits import limits_table  # noqa: E402
from updating.simulate.meter import with_lab_records  # noqa: E402
from updating.simulate.scoring import verdict_row  # noqa: E402

KINDS = ("none", "pine_tar", "grip_tape", "spray", "tar_past_18", "nails", "shaved",
         "flattened", "grooved", "wax", "cork", "neutral", "empty")
"""The kinds run by default, in the table's order."""
CORE_KINDS = ("cork", "deep", "empty", "end_plug", "partial", "small", "neutral")
REGION_TOL_IN = 1.5
ORIENTATIONS = 4
"""The re-test profile's orientations (0, 45, 90, 135 deg)."""
BALANCE_SEED = 2
"""The clean bats' seed for the balance-point limit (bench_detection.py's default)."""


def one(job: tuple) -> dict:
    """Draw, write and inspect one bat; return its result row.

    Parameters
    ----------
    job : tuple
        (kind, seed, with retest.json, with the re-test profile, records); records N:
        the lab's dates, rooms and N moisture readings a station in meta.json and
        retest.json (``updating.simulate.meter.with_lab_records``), None: none.

    Returns
    -------
    dict
        ``updating.simulate.scoring.verdict_row`` plus with_meta, with_profile, finding,
        region_ok and kind_ok.
    """
    kind, seed, with_meta, with_profile, records = job
    try:
        case = draw_case(np.random.default_rng(seed), kind, serial=f"R-{seed}")
        if records is not None:
            case = with_lab_records(case, seed, records)
        with tempfile.TemporaryDirectory(prefix="batlab-rulebook-") as tmp:
            paths = write_case(case, tmp, seed, retest_meta_keys=None if with_meta else [],
                               retest_profile=ORIENTATIONS if with_profile else 0,
                               registration=records is not None)
            args = inspect_args(paths)
            if with_profile:
                args[-1:-1] = ["--retest-profile", paths["retest_profile"]]
            out, err, seconds = timed(args)
    except ValueError as exc:  # the simulator could not make this bat: reported, not counted
        return {"kind": kind, "seed": seed, "with_meta": with_meta,
                "with_profile": with_profile, "status": "error", "error": str(exc),
                "seconds": 0.0}
    row = verdict_row(out, err, seconds, case.truth)
    row.update(seed=seed, with_meta=with_meta, with_profile=with_profile,
               finding=None if out is None else out.get("finding"))
    return score(row)


def score(row: dict) -> dict:
    """Add region_ok and kind_ok to a row (None where they do not apply)."""
    truth = row["truth"]
    found = row["status"] == "altered" and truth.get("altered")
    true_region = (truth.get("finding") or {}).get("region_in") or truth.get("region_in")
    row["region_ok"] = None
    if found and row.get("region_in") and true_region:
        row["region_ok"] = abs(row["region_in"][0] - true_region[0]) <= REGION_TOL_IN
    true_kind = (truth.get("finding") or {}).get("kind") or (
        "core" if row["kind"] in CORE_KINDS else None)
    row["kind_ok"] = None
    if row.get("finding") and true_kind:
        row["kind_ok"] = row["finding"].get("kind") == true_kind
    return row


def ratio(rows: list[dict], key: str) -> str:
    """Return "k/n" of the rows where ``key`` is True, over those where it applies."""
    vals = [r[key] for r in rows if r.get(key) is not None]
    return f"{sum(vals)}/{len(vals)}" if vals else "-"


def table(rows: list[dict]) -> str:
    """Return the markdown table: per kind and way inspected, the statuses and readings."""
    lines = ["| kind | retest.json (+ re-test profile) | bats | altered | not_altered "
             "| inconclusive | refused/error | start within 1.5 in | finding kind right "
             "| median s |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    kinds = [k for k in KINDS if any(r["kind"] == k for r in rows)]
    kinds += sorted({r["kind"] for r in rows} - set(kinds))
    for kind in kinds:
        for meta, profile in ((True, False), (False, False), (True, True)):
            rs = [r for r in rows if r["kind"] == kind and r["with_meta"] == meta
                  and bool(r.get("with_profile")) == profile]
            if not rs:
                continue
            c = {s: sum(r["status"] == s for r in rs) for s in
                 ("altered", "not_altered", "inconclusive")}
            bad = sum(r["status"] in ("refused", "error") for r in rs)
            t = sorted(r["seconds"] for r in rs)
            way = ("yes" if meta else "no") + (" + profile" if profile else "")
            lines.append(f"| {kind} | {way} | {len(rs)} | {c['altered']} | "
                         f"{c['not_altered']} | {c['inconclusive']} | {bad} | "
                         f"{ratio(rs, 'region_ok')} | {ratio(rs, 'kind_ok')} | "
                         f"{t[len(t) // 2]:.1f} |")
    return "\n".join(lines)


def report(rows: list[dict], balance_clean: int) -> None:
    """Print the table and the detection limits (balance limit from ``balance_clean`` bats)."""
    print(table(rows), file=sys.stderr)
    limit = clean_balance_limit_in(balance_clean, BALANCE_SEED)
    print(f"\n## Detection limits\n\n{limits_table(rows, limit)}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark (or re-summarise a run) and print the table on stderr."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", nargs="+", default=list(KINDS))
    ap.add_argument("--per-kind", type=int, default=6, help="bats per kind with retest.json")
    ap.add_argument("--without", type=int, default=3,
                    help="of these, how many also without retest.json")
    ap.add_argument("--with-profile", type=int, default=0,
                    help="of these, how many also with the re-test's caliper profile")
    ap.add_argument("--seed", type=int, default=2400)
    ap.add_argument("--workers", type=int, default=None,
                    help="local Dask worker processes (default: one per core)")
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="a running Dask scheduler (tcp://HOST:PORT) instead of a local cluster")
    ap.add_argument("--summary", default=None, help="summarise a JSON-lines file and stop")
    ap.add_argument("--balance-clean", type=int, default=100, metavar="N",
                    help="clean bats (readings only) that set the balance-point limit")
    ap.add_argument("--records", type=int, default=None, metavar="N",
                    help="the lab's records of the wood and the room in meta.json and "
                         "retest.json: dates, rooms and N moisture readings a station")
    args = ap.parse_args(argv)
    if args.summary:
        lines = Path(args.summary).read_text().splitlines()
        report([json.loads(s) for s in lines if s.strip()], args.balance_clean)
        return 0
    ways = ((True, False, args.per_kind), (False, False, min(args.without, args.per_kind)),
            (True, True, min(args.with_profile, args.per_kind)))
    jobs = [(kind, args.seed + 1000 * k + i, meta, profile, args.records)
            for k, kind in enumerate(args.kinds) for meta, profile, n in ways
            for i in range(n)]
    rows = fleet_map(one, jobs, args.workers, "bat", args.scheduler)
    for row in rows:
        print(json.dumps(row, default=float))
    report(rows, args.balance_clean)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
