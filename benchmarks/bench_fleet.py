"""`batlab fleet` on a Dask cluster: inspect throughput and a calibration's cost per bat.

    nice python benchmarks/bench_fleet.py [--bats 6] [--clean 8] [--seed 1]
                                          [--scheduler tcp://HOST:PORT] [--workers N]

- ``fleet inspect``: ``--bats`` bats registered from the virtual rig (the built-in bat's
  profile under other serials, half of them corked at the re-test), their re-tests in one
  folder, inspected through ``batlab fleet inspect --json``; prints the registry's bytes per
  bat and per inspection, bats a minute per core (wall time x worker threads, the cluster's
  start included) and whether the corked ones, and only they, are called altered.
- ``fleet calibrate``: ``--clean`` clean re-tests of the built-in bat through ``batlab fleet
  calibrate``; prints core-seconds a bat (wall x threads / n) and the workers' CPU seconds
  a bat (what a bat costs whatever else runs on the machine).

Without ``--scheduler`` a local cluster of ``--workers`` processes (default one per core).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import batlab.pipeline as pipeline  # noqa: E402
from batlab.cli import main as batlab  # noqa: E402
from batlab.fleet.cluster import local_workers  # noqa: E402

CORK = "cork:depth=10,d=1.0,ratio=0.3,plug=1"


def run(args: list) -> tuple[int, str]:
    """Run a `batlab` command line here; its exit code and stdout."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = batlab([str(a) for a in args])
    return code, out.getvalue()


def lab(tmp: Path, bats: int, seed: int) -> tuple[Path, Path, list[bool]]:
    """Register ``bats`` bats and write their re-tests (every other one corked)."""
    db, folder = tmp / "league.sqlite", tmp / "retests"
    folder.mkdir()
    corked = [b % 2 == 1 for b in range(bats)]
    for b in range(bats):
        serial, work = f"FLT-{b + 1:03d}", tmp / f"bat{b}"
        work.mkdir()
        files = pipeline.simulate_demo_pair(work, seed + 2 * b,
                                            alteration=CORK if corked[b] else None)
        files.meta.write_text(json.dumps(dict(json.loads(files.meta.read_text()),
                                              serial=serial)))
        code, _ = run(["register", "--profile", files.profile, "--meta", files.meta,
                       "--baseline", files.baseline, "--db", db])
        if code != 0:
            raise SystemExit(f"register {serial} failed")
        (folder / f"{serial}.uff").write_bytes(files.retest.read_bytes())
    return db, folder, corked


def db_bytes(db: Path) -> int:
    """Return the bytes of a SQLite registry and its write-ahead log."""
    return sum(p.stat().st_size for p in (db, db.with_name(db.name + "-wal")) if p.is_file())


def cluster_args(a: argparse.Namespace) -> list:
    """Return the ``--scheduler`` option when one is given."""
    return ["--scheduler", a.scheduler] if a.scheduler else []


def bench_inspect(a: argparse.Namespace, threads: int) -> None:
    """Time ``fleet inspect`` over a folder of re-tests and print its throughput."""
    with tempfile.TemporaryDirectory(prefix="bench-fleet-") as tmp:
        db, folder, corked = lab(Path(tmp), a.bats, a.seed)
        registered = db_bytes(db)
        t0 = time.perf_counter()
        code, out = run(["fleet", "inspect", folder, "--db", db, "--json", *cluster_args(a)])
        wall = time.perf_counter() - t0
        inspected = db_bytes(db) - registered
    print(f"registry (SQLite): {registered / a.bats / 1e3:.0f} kB a registered bat, "
          f"{inspected / a.bats / 1e3:.0f} kB an inspection (the test files kept included)")
    said = [o.get("status") == "altered" for o in json.loads(out)]
    print(f"fleet inspect: {a.bats} re-tests in {wall:.1f} s on {threads} worker(s): "
          f"{60 * a.bats / (wall * threads):.1f} bats a minute per core "
          f"(corked called altered, clean not: {said == corked}; exit {code})")


def bench_calibrate(a: argparse.Namespace, threads: int) -> None:
    """Time ``fleet calibrate`` and print its cost per clean bat."""
    with tempfile.TemporaryDirectory(prefix="bench-fleet-") as tmp:
        rows_path = Path(tmp) / "rows.jsonl"
        t0 = time.perf_counter()
        code, out = run(["fleet", "calibrate", "--profile",
                         pipeline.bench.builtin_dir() / "profile.csv", "--meta",
                         pipeline.bench.builtin_dir() / "meta.json", "--n", a.clean, "--seed",
                         a.seed, "--json", "-o", rows_path, *cluster_args(a)])
        wall = time.perf_counter() - t0
        rows = [json.loads(s) for s in rows_path.read_text().splitlines()]
    summary = json.loads(out)
    cpu = sum(r["cpu_s"] for r in rows) / len(rows)
    print(f"fleet calibrate: {a.clean} clean bats in {wall:.1f} s on {threads} worker(s): "
          f"{wall * threads / a.clean:.1f} core-s a bat, {cpu:.1f} CPU s a bat; "
          f"false alarms {summary['false_alarms']}, upper95 "
          f"{summary['false_alarm_upper95']:.3g} (exit {code})")


def main(argv: list[str] | None = None) -> int:
    """Run both measurements and print one line each."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bats", type=int, default=6, help="re-tests for fleet inspect")
    ap.add_argument("--clean", type=int, default=8, help="clean bats for fleet calibrate")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS")
    ap.add_argument("--workers", type=int, default=None,
                    help="threads the cluster has (default: one per core here)")
    a = ap.parse_args(argv)
    threads = a.workers or local_workers()
    bench_inspect(a, threads)
    bench_calibrate(a, threads)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
