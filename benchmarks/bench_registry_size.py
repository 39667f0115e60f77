"""Registry size per bat and per inspection, on a SQLite file and on a PostgreSQL server.

Registers the sample bat once on the real pipeline (data_samples/smooth_bat) and inspects its
corked re-test once, then stores N more bats and M inspections of each with the same records
(the same reference, modes, verdict and inputs) and files of the same size made distinct (a
serial appended), so the growth is that of real records. Prints the bytes a bat and an
inspection add: the file's size after a WAL checkpoint, or the server's
``pg_total_relation_size`` of the registry's tables (with TOAST and indexes).

    python benchmarks/bench_registry_size.py --db /tmp/size.sqlite [-n 20] [-m 2]
    python benchmarks/bench_registry_size.py --db postgresql://user@/db?host=/socket/dir
"""

from __future__ import annotations

import argparse
import dataclasses
import os
from pathlib import Path

from batlab import registry as reg
from batlab.pipeline.registered import inspect_registered, register_files
from batlab.pipeline.stored import store_inspection

SAMPLE = Path(__file__).resolve().parents[1] / "data_samples" / "smooth_bat"


def size_bytes(conn, db: str) -> int:
    """Return the registry's size: the SQLite file (checkpointed) or the tables on the server."""
    if conn.dialect.name == "sqlite":
        conn.exec_driver_sql("PRAGMA wal_checkpoint(TRUNCATE)")
        return os.path.getsize(db)
    tables = ", ".join(f"'{t.name}'" for t in reg.schema.TABLES)
    return int(conn.exec_driver_sql(
        f"SELECT sum(pg_total_relation_size(c.oid)) FROM pg_class c WHERE c.relname IN "
        f"({tables})").scalar())


def measure(db: str, n_bats: int, n_inspections: int) -> tuple[float, float]:
    """Return (bytes per bat, bytes per inspection) over ``n_bats`` x ``n_inspections``."""
    with reg.open_registry(db) as conn:
        first = register_files(conn, SAMPLE / "profile.csv", SAMPLE / "meta.json",
                               SAMPLE / "baseline.uff").record
        result = inspect_registered(conn, first.serial, SAMPLE / "retest_corked.uff")
        stored = store_inspection(conn, result, SAMPLE / "retest_corked.uff")
        baseline = (SAMPLE / "baseline.uff").read_bytes()
        retest = (SAMPLE / "retest_corked.uff").read_bytes()
        start = size_bytes(conn, db)
        for k in range(n_bats):
            serial = f"SIZE-{k:05d}"
            reg.add_bat(conn, dataclasses.replace(first, serial=serial), "baseline.uff",
                        baseline + serial.encode())
        after_bats = size_bytes(conn, db)
        for k in range(n_bats):
            serial = f"SIZE-{k:05d}"
            for j in range(n_inspections):
                reg.add_inspection(conn, serial, {**stored.verdict, "serial": serial},
                                   "retest.uff", retest + f"{serial}/{j}".encode(),
                                   inputs=stored.inputs)
        end = size_bytes(conn, db)
    return (after_bats - start) / n_bats, (end - after_bats) / (n_bats * n_inspections)


def main() -> None:
    """Measure and print the sizes."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--db", required=True, help="an empty registry: SQLite file or URL")
    ap.add_argument("-n", type=int, default=20, help="bats to store")
    ap.add_argument("-m", type=int, default=2, help="inspections of each")
    args = ap.parse_args()
    per_bat, per_inspection = measure(args.db, args.n, args.m)
    size = (SAMPLE / "baseline.uff").stat().st_size
    print(f"{reg.shown(args.db)}: {per_bat / 1e6:.3f} MB a bat, {per_inspection / 1e6:.3f} MB "
          f"an inspection (each stores a {size / 1e6:.3f} MB UFF file)")


if __name__ == "__main__":
    main()
