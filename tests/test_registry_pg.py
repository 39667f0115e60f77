"""The registry on a real PostgreSQL 15 server (tests/pg_server.py, a server per test
worker): `register` and `inspect --serial` give the verdicts a SQLite file gives, `registry
check` passes and notices a forged verdict, four registrations started at once all land in one
unbroken chain. Numerics are the test-only stand-ins, as in tests/test_registry_cli.py."""

from __future__ import annotations

import json
import multiprocessing as mp
from pathlib import Path

import pytest

from batlab import registry as reg
from tests.inspect_standins import (
    bat_folders,
    lab_worker,
    run_cli,
    stand_in_lab,
    unchanged_retest,
)

# the time, the place, and a custody record's hash (it covers the record's time stamp)
VARIES = ("registered_at", "inspected_at", "last_inspected_at", "db", "record_sha256")


@pytest.fixture
def lab(tmp_path, monkeypatch):
    return stand_in_lab(tmp_path, monkeypatch)


def session(lab: Path, db, capsys) -> dict:
    """A lab's morning on registry ``db``: register, inspect the corked and the unchanged
    re-test, list the bats and the history (JSON of each, less what ``VARIES``)."""
    def cli(*args) -> dict | list:
        code, out, err = run_cli([*args, "--db", db, "--json"], capsys)
        assert code == 0, err
        return json.loads(out)

    registered = cli("register", "--profile", lab / "profile.csv", "--meta", lab / "meta.json",
                     "--baseline", lab / "baseline.uff")
    corked = cli("inspect", "--serial", "HX-2001", lab / "retest_corked.uff")
    same = cli("inspect", "--serial", "HX-2001", unchanged_retest(lab / "baseline.uff",
                                                                  lab / "second.uff"))
    shown = {"register": registered, "corked": corked, "same": same,
             "bats": cli("bats"), "history": cli("history", "HX-2001")}
    return json.loads(json.dumps(shown), object_hook=lambda d: {
        k: v for k, v in d.items() if k not in VARIES})


def test_postgres_gives_the_verdicts_sqlite_gives(lab, pg_url, capsys):
    on_file = session(lab, lab / "reg.sqlite", capsys)
    on_server = session(lab, pg_url, capsys)
    assert on_server["corked"]["status"] == "altered"
    assert on_server["same"]["status"] == "not_altered"
    assert on_server == on_file  # same verdicts, files, record numbers, payload hashes
    code, out, _ = run_cli(["registry", "check", "--db", pg_url, "--json"], capsys)
    res = json.loads(out)
    # baseline file, registration, corked file, its verdict, the second file, its verdict
    assert code == 0 and res["ok"] and res["n_records"] == 6 and res["n_files"] == 3
    code, out, _ = run_cli(["registry", "head", "--db", pg_url], capsys)
    assert code == 0 and out.strip() == res["head"]


def test_a_forged_verdict_on_the_server_is_found(lab, pg_url, capsys):
    session(lab, pg_url, capsys)
    code, head, _ = run_cli(["registry", "head", "--db", pg_url], capsys)
    with reg.open_registry(pg_url) as conn:
        conn.exec_driver_sql("UPDATE inspections SET verdict_json = replace(verdict_json, "
                             "'\"altered\": true', '\"altered\": false') WHERE id = 1")
    code, out, _ = run_cli(["registry", "check", "--db", pg_url, "--head", head.strip()],
                           capsys)
    assert code == 1
    assert "problem: inspection #1: stored verdict differs from custody record #4" in out
    code, _, err = run_cli(["bats", "--db", pg_url.replace("/test_", "/nothere_")], capsys)
    assert code == 2 and "cannot open the PostgreSQL registry" in err and len(
        err.strip().splitlines()) == 1


def test_four_registrations_at_once_all_land(tmp_path, pg_url):
    """Four processes register a bat each and inspect it twice, all at once, on a registry
    none of them found created: every bat and verdict is there, one chain, no fork."""
    ctx = mp.get_context("spawn")
    procs = [ctx.Process(target=lab_worker, args=(pg_url, str(folder), 2))
             for folder in bat_folders(tmp_path, "PG", 4)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(180)
    assert [p.exitcode for p in procs] == [0, 0, 0, 0]
    with reg.open_registry(pg_url) as conn:
        assert [b.serial for b in reg.list_bats(conn)] == ["PG-0", "PG-1", "PG-2", "PG-3"]
        assert all(len(reg.history(conn, f"PG-{k}")) == 2 for k in range(4))
        res = reg.check(conn)
        # 2 files + 4 registrations + 8 verdicts, numbered 1..14 whatever the interleaving
        assert res.ok and res.n_records == 14 and res.n_files == 2, res.problems
        seqs = [r.seq for r in reg.custody_rows(conn)]
        assert seqs == list(range(1, 15))
