"""Faults around the registry named for what they are (issue 48): a registry busy past the
wait (who holds it, how long batlab waited), a full disk, an empty file a killed first
`register` left, a read-only mount; none is called damaged, none changes the file, none prints
a traceback. The numerics are the test-only stand-ins."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.inspect_standins import run_cli, stand_in_lab, unchanged_retest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def lab(tmp_path, monkeypatch):
    return stand_in_lab(tmp_path, monkeypatch)


def register(lab: Path, capsys, db: Path | None = None) -> None:
    code, _, err = run_cli(["register", "--profile", lab / "profile.csv", "--meta",
                            lab / "meta.json", "--baseline", lab / "baseline.uff",
                            *(["--db", db] if db else [])], capsys)
    assert code == 0, err


def history_ids(capsys, db) -> list[int]:
    code, out, err = run_cli(["history", "HX-2001", "--db", db, "--json"], capsys)
    assert code == 0, err
    return [i["id"] for i in json.loads(out)["inspections"]]


def test_a_busy_registry_is_busy_not_damaged(lab, capsys, monkeypatch):
    import batlab.registry.engine as engine

    register(lab, capsys)
    db = lab / "reg.sqlite"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sqlite3, sys, time\n"
         "c = sqlite3.connect(sys.argv[1], isolation_level=None)\n"
         "c.execute('BEGIN IMMEDIATE'); print('held', flush=True); time.sleep(60)", str(db)],
        stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        monkeypatch.setattr(engine, "BUSY_TIMEOUT_S", 0.5)  # the wait, shortened
        code, out, err = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff"],
                                 capsys)
    finally:
        holder.kill()
        holder.wait()
    (line,) = err.strip().splitlines()[-1:]
    assert code == 2 and "damaged" not in err and "registry check" not in err, err
    assert f"{db}: registry busy: its write lock is held by pid {holder.pid} (" in line
    assert "batlab waited 1 s for it" in line or "batlab waited 0 s for it" in line
    assert history_ids(capsys, db) == []  # nothing stored, and it reads as before


def test_a_full_disk_is_full_not_damaged(lab, capsys, monkeypatch):
    import sqlite3

    import batlab.registry.engine as engine

    register(lab, capsys)
    db = lab / "reg.sqlite"
    pages = sqlite3.connect(db).execute("PRAGMA page_count").fetchone()[0]
    enable_wal = engine._enable_wal

    def on_a_full_disk(raw, *args):  # room for 50 more pages, not for the re-test's 0.9 MB
        enable_wal(raw, *args)
        raw.execute(f"PRAGMA max_page_count = {pages + 50}")  # SQLITE_FULL, as ENOSPC gives

    monkeypatch.setattr(engine, "_enable_wal", on_a_full_disk)
    before = db.read_bytes()
    code, out, err = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff"],
                             capsys)
    assert code == 2 and "damaged" not in err and "Traceback" not in err, err
    assert f"{db}: disk full (database or disk is full): nothing was stored" in err
    monkeypatch.undo()
    stand_in_lab(lab, monkeypatch)
    assert history_ids(capsys, db) == [] and db.read_bytes() == before
    code, out, _ = run_cli(["registry", "check"], capsys)
    assert code == 0, out


def test_an_empty_registry_file_is_empty_and_left_empty(lab, capsys):
    db = lab / "reg.sqlite"
    db.write_bytes(b"")  # a first `register` killed before its commit
    for args in (["bats"], ["registry", "check"], ["registry", "head"], ["history", "HX-2001"],
                 ["export", "-o", lab / "h.csv"], ["report", "HX-2001", "-o", lab / "r"],
                 ["inspect", "--serial", "HX-2001", lab / "retest_corked.uff"]):
        code, out, err = run_cli(args, capsys)
        assert code == 2 and out == "", (args, err)
        assert f"{db}: holds no registry yet (an empty 0-byte file" in err, (args, err)
        assert "read-only" not in err and "Traceback" not in err
        assert db.stat().st_size == 0 and sorted(p.name for p in lab.glob("reg*")) == \
            ["reg.sqlite"], args  # refused, the file as it was
    register(lab, capsys)  # the one command that makes a registry makes it there
    assert run_cli(["bats", "--json"], capsys)[0] == 0


def _in_a_mount_namespace(script: str) -> subprocess.CompletedProcess:
    """Run a shell script as root of a new user and mount namespace (``unshare -rm``)."""
    return subprocess.run(["unshare", "-rm", "sh", "-euc", script], capture_output=True,
                          text=True, cwd=ROOT, timeout=300)


def _mounts_allowed() -> bool:
    if shutil.which("unshare") is None:
        return False
    try:
        return _in_a_mount_namespace("mount -t tmpfs tmpfs /mnt").returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


@pytest.mark.skipif(not _mounts_allowed(), reason="needs `unshare -rm` (user and mount "
                    "namespaces) for a read-only bind mount; as root a chmod cannot make a "
                    "registry read-only")
def test_a_registry_on_a_read_only_mount_is_read_without_traceback(lab, capsys):
    register(lab, capsys)
    assert run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff"], capsys)[0] == 0
    shelf = lab / "shelf"
    shelf.mkdir()
    shutil.copyfile(lab / "reg.sqlite", shelf / "reg.sqlite")
    before = (shelf / "reg.sqlite").read_bytes()
    py = f"{sys.executable} -c 'import sys; from tests.inspect_standins import " \
         f"main_with_standins as m; sys.exit(m(sys.argv[1:]))'"
    db = shelf / "reg.sqlite"
    second = unchanged_retest(lab / "baseline.uff", lab / "second.uff")
    runs = [("bats",), ("history", "HX-2001"), ("registry", "head"), ("registry", "check"),
            ("inspect", "--serial", "HX-2001", str(second))]
    script = f"mount --bind {shelf} {shelf}; mount -o remount,bind,ro {shelf} {shelf}; " \
             f"set +e; touch {shelf}/x 2>/dev/null && echo WRITABLE; " + "; ".join(
                 f"{py} {' '.join(r)} --db {db} >{lab}/out{k} 2>{lab}/err{k}; echo $? "
                 f">{lab}/rc{k}" for k, r in enumerate(runs))
    done = _in_a_mount_namespace(script)
    assert done.returncode == 0 and "WRITABLE" not in done.stdout, done.stderr
    for k, r in enumerate(runs):
        rc = int((lab / f"rc{k}").read_text())
        out, err = (lab / f"out{k}").read_text(), (lab / f"err{k}").read_text()
        assert "Traceback" not in err and "Exception" not in err, (r, err)
        if r[0] == "inspect":  # refused at the door, before any work, in one line
            assert rc == 2 and err.count("\n") == 1 and "fitting" not in err, err
            assert f"{db}: registry is read-only (on a read-only file system)" in err
        else:
            assert rc == 0 and out and not err, (r, err)
    assert (lab / "out3").read_text().startswith(f"{db}: intact")
    assert db.read_bytes() == before and sorted(p.name for p in shelf.iterdir()) == \
        ["reg.sqlite"]


def _bench_faults():
    """benchmarks/bench_faults.py as a module (its lab, commands and judgement)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("bench_faults",
                                                  ROOT / "benchmarks" / "bench_faults.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _strace_injects() -> bool:
    if shutil.which("strace") is None:
        return False
    done = subprocess.run(["strace", "-qq", "-o", "/dev/null", "-e", "trace=getppid", "-e",
                           "inject=getppid:signal=SIGKILL:when=1", sys.executable, "-c",
                           "import os; os.getppid()"], capture_output=True, timeout=60)
    return done.returncode in (137, -9)


@pytest.mark.skipif(not _strace_injects(), reason="needs strace with fault injection (and "
                    "ptrace allowed); benchmarks/bench_faults.py runs 200 such kills")
def test_a_kill_at_a_system_call_loses_and_doubles_nothing(tmp_path):
    """One of the benchmark's kills (an inspection at its commit's second sync): the registry
    checks, nothing is lost, and the command run again leaves one inspection."""
    what, syscall, k = "inspect", "fdatasync", 2
    bench = _bench_faults()
    files = bench.lab(tmp_path)
    db = tmp_path / "reg.sqlite"
    bench.prepare(files, what, db)
    before = bench.snapshot(db)
    argv = [str(a) for a in bench.commands(files, db)[what]]
    proc = subprocess.run([*bench.strace_argv(db, ["-o", "/dev/null", "-e", f"trace={syscall}",
                                                   "-e", f"inject={syscall}:signal=SIGKILL:"
                                                   f"when={k}"]),
                           sys.executable, "-c", bench.RUNNER.format(root=str(ROOT)), *argv],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode in (137, -9), proc.stderr  # killed there
    res = bench.judge(db, before, what, argv)
    assert (res["broken"], res["lost"], res["duplicated"], res["rerun_failed"]) == \
        (0, 0, 0, 0), res["why"]
