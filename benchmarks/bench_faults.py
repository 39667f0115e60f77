"""Fault injection: `register` and `inspect` killed at random system calls on the registry.

Each run copies a small lab registry (one bat, one inspection), starts `batlab inspect
--serial` or `batlab register` (a second bat, or the first into no registry at all) in a
subprocess under ``strace``, and has the kernel's tracer kill it (SIGKILL) at the K-th call of
one system call on the registry's files (``strace -P FILE -e inject=SYSCALL:signal=SIGKILL:
when=K``): a write of a page, a sync, a lock, the log's truncation, a read, an open. SYSCALL
is drawn in proportion to how often an unkilled run makes it, K uniformly among its calls, so
the kills fall everywhere a run touches the registry: mid-transaction, mid-WAL, at the
commit's sync, in the checkpoint on close. Then, in this process:

- ``registry check`` (the library's ``check``): a registry that fails it counts as broken
  (a file left empty by a killed first `register` counts as intact when nothing was there);
- every custody record, bat and inspection there before the kill must still be there, the
  same: one missing is a lost record;
- the same command is run again, unkilled (a lab re-running it): it must end well (a
  registration that did land is "already registered", an inspection that did land "already
  inspected"), and after it the bat has exactly one registration record and the re-test
  exactly one inspection: two are a duplicated record, none a lost one.

The numerics are the test-only stand-ins (``tests/inspect_standins.py``: the registry's
crash safety is measured, not the modal fit's), so a run takes a second or two.

    python benchmarks/bench_faults.py [--runs 200] [--seed 48] [--keep DIR]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from batlab import registry as reg  # noqa: E402
from tests.inspect_standins import SAMPLE, main_with_standins, unchanged_retest  # noqa: E402

RUNNER = ("import sys; sys.path.insert(0, {root!r}); from tests.inspect_standins import "
          "main_with_standins as m; sys.exit(m(sys.argv[1:]))")
SYSCALLS = ("pwrite64", "pread64", "fdatasync", "fsync", "ftruncate", "unlink", "fcntl",
            "openat")


def cli(argv: list) -> tuple[int, str]:
    """Run ``batlab argv`` in this process (stand-in numerics): exit code, stderr."""
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main_with_standins([str(a) for a in argv])
    return code, err.getvalue()


def lab(root: Path) -> dict:
    """The lab's files and its registry: one bat, one inspection (of a second clean test)."""
    for name in ("profile.csv", "meta.json", "baseline.uff", "retest_corked.uff"):
        shutil.copyfile(SAMPLE / name, root / name)
    meta = json.loads((root / "meta.json").read_text())
    (root / "meta2.json").write_text(json.dumps({**meta, "serial": "HX-2002"}))
    unchanged_retest(root / "baseline.uff", root / "second.uff")
    db = root / "base.sqlite"
    for argv in (["register", "--profile", root / "profile.csv", "--meta", root / "meta.json",
                  "--baseline", root / "baseline.uff", "--db", db],
                 ["inspect", "--serial", "HX-2001", root / "second.uff", "--db", db]):
        code, err = cli(argv)
        assert code == 0, err
    return {"root": root, "base": db}


def commands(files: dict, db: Path) -> dict[str, list]:
    """The commands killed: an inspection, a second bat, the first bat into no registry."""
    root = files["root"]
    return {
        "inspect": ["inspect", "--serial", "HX-2001", root / "retest_corked.uff", "--db", db],
        "register": ["register", "--profile", root / "profile.csv", "--meta",
                     root / "meta2.json", "--baseline", root / "retest_corked.uff", "--db", db],
        "first register": ["register", "--profile", root / "profile.csv", "--meta",
                           root / "meta.json", "--baseline", root / "baseline.uff", "--db", db],
    }


def strace_argv(db: Path, extra: list[str]) -> list[str]:
    paths = [a for p in (db, Path(f"{db}-wal"), Path(f"{db}-shm")) for a in ("-P", str(p))]
    return ["strace", "-f", "-qq", *paths, *extra]


def prepare(files: dict, what: str, db: Path) -> None:
    for p in (db, Path(f"{db}-wal"), Path(f"{db}-shm")):
        p.unlink(missing_ok=True)
    if what != "first register":
        shutil.copyfile(files["base"], db)


def syscall_counts(files: dict, what: str, db: Path) -> dict[str, int]:
    """How often an unkilled run calls each of ``SYSCALLS`` on the registry's files."""
    prepare(files, what, db)
    table = db.parent / "counts.txt"
    argv = [str(a) for a in commands(files, db)[what]]
    subprocess.run([*strace_argv(db, ["-c", "-o", str(table)]), sys.executable, "-c",
                    RUNNER.format(root=str(ROOT)), *argv], capture_output=True, check=True)
    counts = {}
    for line in table.read_text().splitlines():
        parts = line.split()
        if parts and parts[-1] in SYSCALLS and parts[3].isdigit():
            counts[parts[-1]] = int(parts[3])
    return counts


NOTHING = {"records": {}, "bats": set(), "inspections": {}}


def snapshot(db: Path) -> dict:
    """What the registry holds: custody records, bats, inspections (empty if none)."""
    try:
        with reg.open_registry(db, create=False, readonly=True) as conn:
            return {"records": {r.seq: r.record_sha256 for r in reg.custody_rows(conn)},
                    "bats": {b.serial for b in reg.list_bats(conn)},
                    "inspections": {i.id: i.record_sha256 for i in reg.all_inspections(conn)}}
    except ValueError as exc:  # none there, or a file a killed first register left empty
        if "no registry there" in str(exc) or "holds no registry yet" in str(exc):
            return NOTHING
        raise


def judge(db: Path, before: dict, what: str, argv: list) -> dict:
    """Check, compare with ``before``, re-run unkilled, count what is broken, lost, doubled."""
    out = {"broken": 0, "lost": 0, "duplicated": 0, "rerun_failed": 0, "why": []}
    try:
        with reg.open_registry(db, create=False, readonly=True) as conn:
            res = reg.check(conn)
    except ValueError as exc:  # none, or an empty file left by a killed first register
        empty = "no registry there" in str(exc) or "holds no registry yet" in str(exc)
        if not empty or before["records"]:
            out["broken"] += 1
            out["why"].append(str(exc))
    else:
        if not res.ok:
            out["broken"] += 1
            out["why"] += res.problems[:2]
    try:
        after = snapshot(db)
    except ValueError:  # counted above
        after = NOTHING
    for key in ("records", "inspections"):
        gone = [k for k, v in before[key].items() if after[key].get(k) != v]
        out["lost"] += len(gone)
    out["lost"] += len(before["bats"] - after["bats"])
    code, err = cli(argv)
    landed_before = "already registered" in err or "already inspected" in err
    if code != 0 and not (what != "inspect" and "already registered" in err):
        out["rerun_failed"] += 1
        out["why"].append(err.strip().splitlines()[-1] if err.strip() else f"exit {code}")
    with reg.open_registry(db, create=False, readonly=True) as conn:
        res = reg.check(conn)
        if not res.ok:
            out["broken"] += 1
            out["why"] += res.problems[:2]
        if what == "inspect":
            sha = reg.sha256_bytes(Path(argv[3]).read_bytes())
            n = sum(i.retest_sha256 == sha for i in reg.all_inspections(conn))
        else:
            serial = "HX-2002" if what == "register" else "HX-2001"
            n = sum(r.kind == "reference" and r.subject == serial
                    for r in reg.custody_rows(conn))
    out["duplicated"] += max(n - 1, 0)
    out["lost"] += n == 0
    out["landed_before_rerun"] = landed_before
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--seed", type=int, default=48)
    ap.add_argument("--keep", default=None, help="keep the work folder here")
    args = ap.parse_args()
    if shutil.which("strace") is None:
        sys.exit("bench_faults: needs strace (its -e inject kills the run at a system call)")
    rng = random.Random(args.seed)
    work = Path(args.keep or tempfile.mkdtemp(prefix="bench-faults-"))
    work.mkdir(parents=True, exist_ok=True)
    files = lab(work)
    db = work / "reg.sqlite"
    kinds = list(commands(files, db))
    counts = {what: syscall_counts(files, what, db) for what in kinds}
    for what, c in counts.items():
        print(f"{what}: system calls on the registry in one run: "
              + ", ".join(f"{k} {v}" for k, v in sorted(c.items())), flush=True)
    totals = {k: 0 for k in ("runs", "killed", "broken", "lost", "duplicated", "rerun_failed",
                             "landed_before_rerun")}
    by_kind = {what: dict.fromkeys(totals, 0) for what in kinds}
    start = time.perf_counter()
    for run in range(args.runs):
        what = kinds[run % len(kinds)] if run < len(kinds) else rng.choice(
            ["inspect", "inspect", "register", "first register"])
        calls = counts[what]
        syscall = rng.choices(list(calls), weights=list(calls.values()))[0]
        k = rng.randint(1, calls[syscall])
        prepare(files, what, db)
        before = snapshot(db)
        argv = [str(a) for a in commands(files, db)[what]]
        proc = subprocess.run(
            [*strace_argv(db, ["-o", "/dev/null", "-e", f"trace={syscall}", "-e",
                               f"inject={syscall}:signal=SIGKILL:when={k}"]),
             sys.executable, "-c", RUNNER.format(root=str(ROOT)), *argv],
            capture_output=True, text=True)
        killed = proc.returncode in (137, -9) or "Killed" in proc.stderr or \
            re.search(r"\+\+\+ killed by SIGKILL", proc.stderr) is not None
        res = judge(db, before, what, argv)
        for tally in (totals, by_kind[what]):
            tally["runs"] += 1
            tally["killed"] += killed
            for key in ("broken", "lost", "duplicated", "rerun_failed"):
                tally[key] += res[key]
            tally["landed_before_rerun"] += res["landed_before_rerun"]
        flag = "" if not (res["broken"] or res["lost"] or res["duplicated"]
                          or res["rerun_failed"]) else f"  <-- {res['why']}"
        print(f"run {run + 1:3d}: {what:<14} killed at {syscall} #{k:<4d} "
              f"({'killed' if killed else f'exit {proc.returncode}'}){flag}", flush=True)
    took = time.perf_counter() - start
    print(f"\n{totals['runs']} runs in {took:.0f} s; {totals['killed']} killed by the injected "
          f"SIGKILL (a run whose K-th call never came ended on its own)")
    print(f"{'command':<15} {'runs':>5} {'killed':>7} {'landed':>7} {'failing check':>14} "
          f"{'lost':>5} {'duplicated':>11} {'re-run failed':>14}")
    for what, t in [*by_kind.items(), ("all", totals)]:
        print(f"{what:<15} {t['runs']:>5} {t['killed']:>7} {t['landed_before_rerun']:>7} "
              f"{t['broken']:>14} {t['lost']:>5} {t['duplicated']:>11} {t['rerun_failed']:>14}")
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
