"""The SQLite registry: CRUD, checksums, migrations, concurrent writers, killed writers."""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import signal
import sqlite3
import threading
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from batlab import registry as reg


def make_bat(serial: str, n_points: int = 5) -> reg.BatRecord:
    x = [0.0, 0.1, 0.1, 0.5, 0.86]
    d = [0.04, 0.04, 0.025, 0.05, 0.065]
    modes = {"freq_hz": [170.0, 560.0], "damping_ratio": [0.005, 0.007],
             "shapes": [[0.1 * i, -0.2 * i] for i in range(n_points)],
             "x_m": [0.1 * i for i in range(n_points)], "sensor_x_m": 0.4,
             "freq_std_hz": [0.1, 0.2]}
    return reg.BatRecord(serial=serial, profile_x_m=x, profile_diameter_m=d,
                         meta={"serial": serial, "species": "white ash", "weight_lb": 2.2},
                         species="white ash", reference={"E_pa": 1.2e10, "rho_kg_m3": 600.0},
                         modes=modes)


def test_default_path_from_env(tmp_path):
    assert reg.default_db_path({"BATLAB_DB": str(tmp_path / "a.db")}) == tmp_path / "a.db"
    assert reg.default_db_path({"XDG_DATA_HOME": str(tmp_path)}) == (
        tmp_path / "batlab" / "registry.sqlite")
    assert reg.default_db_path({}).parts[-4:] == (".local", "share", "batlab", "registry.sqlite")
    url = "postgresql://lab7:secret@league.example.org/batlab?sslmode=require"
    assert reg.default_db_path({"BATLAB_DB": url}) == url  # a URL stays text, not a Path
    assert reg.shown(url) == "postgresql://lab7@league.example.org/batlab?sslmode=require"
    assert reg.shown("postgresql:///batlab?host=/run/pg") == "postgresql:///batlab?host=/run/pg"
    assert not reg.is_url("postgresql.sqlite") and not reg.is_url(tmp_path / "postgresql:")


def test_register_get_list_history(tmp_path):
    with reg.open_registry(tmp_path / "sub" / "r.sqlite") as conn:
        assert reg.schema_version(conn) == reg.SCHEMA_VERSION
        assert conn.exec_driver_sql("PRAGMA journal_mode").fetchone()[0] == "wal"
        bat = make_bat("HX-1")
        stored = reg.add_bat(conn, bat, "base.uff", b"UFF bytes 1")
        assert stored.baseline_sha256 == reg.sha256_bytes(b"UFF bytes 1")
        assert stored.profile_x_m == bat.profile_x_m
        assert stored.profile_diameter_m == bat.profile_diameter_m
        assert stored.modes == bat.modes and stored.reference == bat.reference
        assert stored.baseline_name == "base.uff" and stored.species == "white ash"
        assert reg.baseline_file(conn, stored) == b"UFF bytes 1"

        with pytest.raises(ValueError, match="already registered"):
            reg.add_bat(conn, make_bat("HX-1"), "other.uff", b"other")
        reg.add_bat(conn, make_bat("HX-0"), "b0.uff", b"zero")

        first = reg.add_inspection(conn, "HX-1", {"altered": False}, "r1.uff", b"aa")
        second = reg.add_inspection(conn, "HX-1", {"altered": True, "x": 1}, "r2.uff", b"bb",
                                    report_path="/tmp/rep")
        third = reg.add_inspection(conn, "HX-1", {"status": "inconclusive", "altered": None,
                                                  "reasons": ["amplitudes disagree"]},
                                   "r2.uff", b"bb")
        hist = reg.history(conn, "HX-1")
        assert [h.id for h in hist] == [first.id, second.id, third.id]
        assert [h.altered for h in hist] == [False, True, None]
        assert [h.status for h in hist] == ["not_altered", "altered", "inconclusive"]
        assert hist[1].verdict == {"altered": True, "x": 1}
        assert hist[1].report_path == "/tmp/rep"
        assert hist[1].retest_sha256 == reg.sha256_bytes(b"bb")
        assert hist[1].baseline_sha256 == stored.baseline_sha256
        assert hist[1].reference_seq == stored.reference_seq
        # the re-test file is kept once (two inspections of the same bytes)
        assert reg.stored_file(conn, hist[2].retest_sha256, "x") == ("r2.uff", b"bb")
        assert conn.exec_driver_sql("SELECT count(*) FROM files").fetchone()[0] == 4

        bats = reg.list_bats(conn)
        assert [b.serial for b in bats] == ["HX-0", "HX-1"]
        assert bats[0].n_inspections == 0 and bats[0].last_altered is None
        assert bats[1].n_inspections == 3 and bats[1].last_altered is None
        assert bats[1].last_status == "inconclusive"

        with pytest.raises(ValueError, match="unknown serial"):
            reg.get_bat(conn, "NOPE")
        with pytest.raises(ValueError, match="unknown serial"):
            reg.history(conn, "NOPE")
        with pytest.raises(ValueError, match="unknown serial"):
            reg.add_inspection(conn, "NOPE", {"altered": False}, "r", b"cc")
        assert reg.check(conn).ok


def test_replace_keeps_history_and_every_file(tmp_path):
    """After --replace each inspection still names, and can rebuild, the registration it was
    judged against; no stored file is ever deleted."""
    with reg.open_registry(tmp_path / "r.sqlite") as conn:
        old = reg.add_bat(conn, make_bat("S1"), "a.uff", b"first")
        reg.add_inspection(conn, "S1", {"altered": False}, "r.uff", b"11")
        shorter = reg.BatRecord(**{**make_bat("S1").__dict__, "profile_x_m": [0.0, 0.8],
                                   "profile_diameter_m": [0.03, 0.06],
                                   "reference": {"E_pa": 1.5e10, "rho_kg_m3": 650.0}})
        new = reg.add_bat(conn, shorter, "b.uff", b"second", replace=True)
        assert new.profile_x_m == [0.0, 0.8] and reg.baseline_file(conn, new) == b"second"
        assert new.reference_seq > old.reference_seq
        reg.add_inspection(conn, "S1", {"altered": True}, "r2.uff", b"22")
        hist = reg.history(conn, "S1")
        assert [h.baseline_sha256 for h in hist] == [old.baseline_sha256, new.baseline_sha256]
        assert [h.reference_seq for h in hist] == [old.reference_seq, new.reference_seq]
        then = reg.bat_as_registered(conn, hist[0].reference_seq)
        assert then.profile_x_m == old.profile_x_m and then.reference == old.reference
        assert then.baseline_name == "a.uff"
        reg.add_bat(conn, make_bat("S1"), "c.uff", b"third", replace=True)
        names = {r[0] for r in conn.exec_driver_sql("SELECT name FROM files")}
        assert names == {"a.uff", "b.uff", "c.uff", "r.uff", "r2.uff"}
        assert reg.check(conn).ok


def test_tampered_baseline_is_detected(tmp_path):
    path = tmp_path / "r.sqlite"
    with reg.open_registry(path) as conn:
        reg.add_bat(conn, make_bat("T1"), "a.uff", b"genuine baseline data")
    raw = sqlite3.connect(path)
    raw.execute("UPDATE files SET content = ?", (b"genuine baseline dat4",))
    raw.commit()
    raw.close()
    with reg.open_registry(path) as conn:
        bat = reg.get_bat(conn, "T1")
        with pytest.raises(ValueError, match="checksum"):
            reg.baseline_file(conn, bat)


def test_failed_transaction_leaves_nothing(tmp_path):
    with reg.open_registry(tmp_path / "r.sqlite") as conn:
        bad = reg.BatRecord(**{**make_bat("B1").__dict__, "profile_diameter_m": [0.04]})
        with pytest.raises(ValueError):  # zip(strict=True) fails after the bat row went in
            reg.add_bat(conn, bad, "a.uff", b"x")
        assert not conn.connection.dbapi_connection.in_transaction  # rolled back
        assert reg.list_bats(conn) == []
        assert conn.exec_driver_sql("SELECT count(*) FROM files").fetchone()[0] == 0
        assert conn.exec_driver_sql("SELECT count(*) FROM custody").fetchone()[0] == 0


def test_migration_from_v1(tmp_path):
    path = tmp_path / "old.sqlite"
    conn = reg.connect(path, target=1)
    assert reg.schema_version(conn) == 1
    prof = {"x_m": [0.0, 0.4, 0.86], "diameter_m": [0.03, 0.035, 0.066]}
    blob = b"old baseline"
    conn.exec_driver_sql(
        "INSERT INTO bats VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
        ("V1", json.dumps(prof), json.dumps({"serial": "V1", "species": "maple"}),
         json.dumps({"E_pa": 1e10}), json.dumps({"freq_hz": [1.0]}), "base.uff",
         reg.sha256_bytes(blob), blob, "2026-01-01T00:00:00+00:00"))
    conn.exec_driver_sql("INSERT INTO inspections (serial, verdict_json, retest_sha256, "
                         "inspected_at) VALUES ('V1', ?, 'abc', '2026-02-01T00:00:00+00:00')",
                         (json.dumps({"serial": "V1", "altered": True}),))
    conn.close()

    with reg.open_registry(path) as conn:
        assert reg.schema_version(conn) == reg.SCHEMA_VERSION == 7
        versions = [r[0] for r in conn.exec_driver_sql("SELECT version_num FROM alembic_version")]
        assert versions == ["0007"]  # Alembic ran 0002..0007 in place
        bat = reg.get_bat(conn, "V1")
        assert bat.profile_x_m == prof["x_m"] and bat.profile_diameter_m == prof["diameter_m"]
        assert bat.species == "maple" and bat.reference == {"E_pa": 1e10}
        assert reg.baseline_file(conn, bat) == blob
        (insp,) = reg.history(conn, "V1")
        assert insp.altered is True and insp.retest_sha256 == "abc"
        assert insp.status == "altered" and insp.reference_seq is None
        assert insp.baseline_sha256 == reg.sha256_bytes(blob)
        # the migration chained what was there: the file, the bat, the verdict (unsigned,
        # schema 3), then schema 4 sealed them with a signed record naming how many
        rows = conn.exec_driver_sql("SELECT kind, signer FROM custody ORDER BY seq").fetchall()
        assert [r[0] for r in rows] == ["file", "reference", "verdict", "seal"]
        assert [r[1] is None for r in rows] == [True, True, True, False]
        columns = conn.exec_driver_sql("PRAGMA table_info(inspections)")
        assert "altered" not in [c[1] for c in columns]
        res = reg.check(conn)
        assert res.ok and res.notes[:-1] == [
            f"inspection #{insp.id}: re-test file not kept (inspected before schema 3)",
            "records #1..#3 are unsigned legacy records (written before schema 4), sealed by "
            "signed record #4",
            "1 file record(s) (#1..#1) were written before file records covered a file's name "
            "and size: their content hash is the file's, their name is checked against the "
            "record's payload, which no hash covers"]
        assert res.notes[-1].startswith("no --trust given: the signatures were checked for "
                                        "consistency only")
        assert conn.exec_driver_sql("PRAGMA foreign_key_check").fetchall() == []
        assert conn.exec_driver_sql("PRAGMA integrity_check").fetchone()[0] == "ok"
        # the migrated database is fully usable
        reg.add_inspection(conn, "V1", {"altered": False}, "r.uff", b"def")
        assert [i.altered for i in reg.history(conn, "V1")] == [True, False]
        assert reg.check(conn).ok


def test_newer_schema_is_refused(tmp_path):
    path = tmp_path / "r.sqlite"
    reg.connect(path).close()
    raw = sqlite3.connect(path)
    raw.execute("UPDATE alembic_version SET version_num = '0099'")
    raw.commit()
    raw.close()
    with pytest.raises(ValueError, match="newer"):
        reg.connect(path)


def test_not_a_database(tmp_path):
    path = tmp_path / "junk.sqlite"
    path.write_bytes(b"this is not sqlite" * 100)
    with pytest.raises(ValueError, match="junk.sqlite"):
        reg.connect(path)


# --- several processes at once -----------------------------------------------------------


def _worker(path: str, worker: int, n: int) -> None:
    with reg.open_registry(path) as conn:
        reg.add_bat(conn, make_bat(f"W{worker}"), f"w{worker}.uff", f"w{worker}".encode())
        shared = None
        for _ in range(1500):  # wait up to 30 s for worker 0's bat (spawned under load)
            try:
                shared = reg.get_bat(conn, "W0")
                break
            except ValueError:
                time.sleep(0.02)
        assert shared is not None
        for k in range(n):
            reg.add_inspection(conn, "W0", {"altered": k % 2 == 0, "by": worker}, "r.uff",
                               f"{worker}-{k}".encode())


def test_concurrent_writers(tmp_path):
    path = str(tmp_path / "busy.sqlite")  # created by the racing workers themselves
    ctx = mp.get_context("spawn")
    procs = [ctx.Process(target=_worker, args=(path, w, 15)) for w in range(4)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(60)
    assert [p.exitcode for p in procs] == [0, 0, 0, 0]
    with reg.open_registry(path) as conn:
        assert [b.serial for b in reg.list_bats(conn)] == ["W0", "W1", "W2", "W3"]
        hist = reg.history(conn, "W0")
        assert len(hist) == 60
        assert sorted(h.retest_sha256 for h in hist) == sorted(
            reg.sha256_bytes(f"{w}-{k}".encode()) for w in range(4) for k in range(15))
        assert conn.exec_driver_sql("SELECT version_num FROM alembic_version").all() == [
            ("0007",)]  # created once at the head, whoever came first
        assert reg.check(conn).ok  # one unbroken chain however the writers interleaved


# --- a writer killed mid-transaction -------------------------------------------------------


def _die_mid_transaction(path: str, ready) -> None:
    conn = reg.connect(path)
    conn.exec_driver_sql("BEGIN IMMEDIATE")
    conn.exec_driver_sql("INSERT INTO files VALUES ('dead', 'dead.uff', 4, x'00112233')")
    conn.exec_driver_sql("INSERT INTO bats (serial, species, meta_json, reference_json, "
                         "modes_json, baseline_sha256, registered_at) VALUES ('DEAD', '', '{}', "
                         "'{}', '{}', 'dead', 'now')")
    ready.set()
    time.sleep(60)  # killed here, before COMMIT


def _inspect_forever(path: str, ready) -> None:
    with reg.open_registry(path) as conn:
        bat = reg.get_bat(conn, "K1")
        k = 0
        while True:
            reg.add_inspection(conn, "K1", {"altered": False, "k": k, "pad": "x" * 5000},
                               "r.uff", str(k).encode(), bat.reference_seq)
            k += 1
            if k == 20:
                ready.set()


def test_killed_writer_leaves_database_consistent(tmp_path):
    path = str(tmp_path / "kill.sqlite")
    with reg.open_registry(path) as conn:
        reg.add_bat(conn, make_bat("K1"), "k.uff", b"k1")
    ctx = mp.get_context("spawn")
    for target in (_die_mid_transaction, _inspect_forever):
        ready = ctx.Event()
        proc = ctx.Process(target=target, args=(path, ready))
        proc.start()
        assert ready.wait(30)
        os.kill(proc.pid, signal.SIGKILL)
        proc.join(10)
        assert proc.exitcode == -signal.SIGKILL
    with reg.open_registry(path) as conn:
        assert conn.exec_driver_sql("PRAGMA integrity_check").fetchone()[0] == "ok"
        assert conn.exec_driver_sql("PRAGMA foreign_key_check").fetchall() == []
        assert [b.serial for b in reg.list_bats(conn)] == ["K1"]  # DEAD never committed
        hist = reg.history(conn, "K1")
        assert len(hist) >= 20
        assert [h.verdict["k"] for h in hist] == list(range(len(hist)))  # no gap, no torn row
        reg.add_inspection(conn, "K1", {"altered": True}, "r.uff", b"after")
        assert reg.history(conn, "K1")[-1].retest_sha256 == reg.sha256_bytes(b"after")
        assert reg.check(conn).ok


def test_missing_registry_not_created_on_read(tmp_path):
    path = tmp_path / "typo" / "r.sqlite"
    with pytest.raises(ValueError, match="no registry there"):
        reg.connect(path, create=False)
    assert not path.parent.exists()


# --- chain of custody ----------------------------------------------------------------------


def _chained(path) -> dict:
    with reg.open_registry(path) as conn:
        reg.add_bat(conn, make_bat("C1"), "base.uff", b"baseline bytes")
        ids = [reg.add_inspection(conn, "C1", {"altered": k == 1, "k": k}, f"r{k}.uff",
                                  f"retest {k}".encode()).id for k in range(3)]
        assert reg.check(conn).ok
        rows = conn.exec_driver_sql("SELECT seq, kind, subject FROM custody ORDER BY seq").all()
    return {"ids": ids, "seq": {(kind, subject): seq for seq, kind, subject in rows}}


def _raw(path, sql, args=()):
    raw = sqlite3.connect(path)
    raw.execute(sql, args)
    raw.commit()
    raw.close()


def _check(path) -> reg.CheckResult:
    with reg.open_registry(path) as conn:
        return reg.check(conn)


def test_chain_names_a_changed_verdict(tmp_path):
    path = tmp_path / "c.sqlite"
    info = _chained(path)
    victim = info["ids"][1]
    _raw(path, "UPDATE inspections SET verdict_json = ? WHERE id = ?",
         (json.dumps({"altered": False, "k": 1}), victim))
    res = _check(path)
    assert not res.ok and res.first_changed == info["seq"][("verdict", str(victim))]
    assert any(f"inspection #{victim}: stored verdict differs" in p for p in res.problems)


def test_chain_names_a_rewritten_record_and_everything_after_stays_linked(tmp_path):
    """Rewriting a record's payload together with its content hash still breaks its own
    record hash (and re-hashing it breaks the next record's link)."""
    path = tmp_path / "c.sqlite"
    info = _chained(path)
    seq = info["seq"][("verdict", str(info["ids"][0]))]
    with reg.open_registry(path) as conn:
        payload = conn.exec_driver_sql("SELECT payload FROM custody WHERE seq = ?",
                                       (seq,)).scalar()
    forged = payload.replace('"altered":false', '"altered":true')
    assert forged != payload
    _raw(path, "UPDATE custody SET payload = ?, content_sha256 = ? WHERE seq = ?",
         (forged, reg.sha256_bytes(forged.encode()), seq))
    res = _check(path)
    assert res.first_changed == seq and f"custody record #{seq} " in res.problems[0]
    assert "hash does not match" in res.problems[0]
    # re-hash the forged record too: its signature no longer verifies and the next record's
    # link breaks
    with reg.open_registry(path) as conn:
        (row,) = [r for r in reg.custody_rows(conn) if r.seq == seq]
    _raw(path, "UPDATE custody SET record_sha256 = ? WHERE seq = ?", (row.expected_hash(), seq))
    res = _check(path)
    assert f"custody record #{seq} " in res.problems[0]
    assert "signature does not verify" in res.problems[0]
    assert f"custody record #{seq + 1} " in res.problems[1]
    assert "link to the previous record" in res.problems[1]
    assert res.first_changed == seq  # the live inspection no longer matches its record either


def test_chain_detects_missing_and_changed_files_and_deleted_records(tmp_path):
    path = tmp_path / "c.sqlite"
    info = _chained(path)
    sha = reg.sha256_bytes(b"retest 2")
    _raw(path, "DELETE FROM files WHERE sha256 = ?", (sha,))
    res = _check(path)
    assert any(f"re-test file {sha[:12]} missing" in p for p in res.problems)
    assert res.first_changed is None  # the chain itself is intact
    _raw(path, "UPDATE files SET content = ? WHERE name = 'base.uff'", (b"baseline bytez",))
    assert any("base.uff" in p and "SHA-256" in p for p in _check(path).problems)
    first_verdict = info["seq"][("verdict", str(info["ids"][0]))]
    _raw(path, "DELETE FROM custody WHERE seq = ?", (first_verdict,))
    res = _check(path)
    assert res.first_changed == first_verdict + 1
    assert any(f"records #{first_verdict}..#{first_verdict} removed" in p for p in res.problems)


def test_read_only_registry_is_readable_and_refuses_writes(tmp_path):
    path = tmp_path / "ro" / "r.sqlite"
    _chained(path)
    os.chmod(path, 0o444)
    os.chmod(path.parent, 0o555)
    try:
        # root may write anything: there the explicit read-only mode is what is tested
        readonly = os.access(path, os.W_OK)
        with reg.open_registry(path, create=False, readonly=readonly) as conn:
            assert [b.serial for b in reg.list_bats(conn)] == ["C1"]
            assert len(reg.history(conn, "C1")) == 3 and reg.check(conn).ok
            with pytest.raises(ValueError, match="read-only"):
                reg.add_inspection(conn, "C1", {"altered": False}, "r.uff", b"new")
    finally:
        os.chmod(path.parent, 0o755)
        os.chmod(path, 0o644)


@settings(max_examples=12, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(n_bats=st.integers(1, 3), n_insp=st.integers(0, 4), pick=st.floats(0, 0.999),
       how=st.sampled_from(["content", "stamp", "subject"]))
def test_chain_names_whichever_record_was_changed(tmp_path, n_bats, n_insp, pick, how):
    """Whatever the history and whichever record is changed (its content hash, its time stamp
    or its subject), `check` names that record as the first changed one."""
    path = tmp_path / f"h{n_bats}{n_insp}{pick}{how}.sqlite"
    with reg.open_registry(path) as conn:
        for b in range(n_bats):
            reg.add_bat(conn, make_bat(f"P{b}"), f"b{b}.uff", f"base {b}".encode())
        for k in range(n_insp):
            reg.add_inspection(conn, f"P{k % n_bats}", {"altered": k % 2 == 0}, f"r{k}.uff",
                               f"retest {k}".encode())
        assert reg.check(conn).ok
        n = conn.exec_driver_sql("SELECT count(*) FROM custody").fetchone()[0]
    seq = 1 + int(pick * n)
    column, value = {"content": ("content_sha256", "f" * 64),
                     "stamp": ("recorded_at", "2000-01-01T00:00:00+00:00"),
                     "subject": ("subject", "someone else")}[how]
    _raw(path, f"UPDATE custody SET {column} = ? WHERE seq = ?", (value, seq))
    res = _check(path)
    assert not res.ok and res.first_changed == seq, res.problems
    path.unlink()


def test_connect_waits_for_another_process_switching_to_wal(tmp_path):
    """While another connection holds the reserved lock, SQLite refuses the switch to WAL at
    once (the lock upgrade could deadlock, so no busy handler); connect must wait, not fail
    (the race behind a CI failure of test_concurrent_writers)."""
    path = tmp_path / "held.sqlite"
    holder = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
    holder.execute("BEGIN IMMEDIATE")
    holder.execute("CREATE TABLE schema_version (version INTEGER NOT NULL, "
                   "applied_at TEXT NOT NULL)")
    timer = threading.Timer(0.3, lambda: holder.execute("COMMIT"))
    timer.start()
    try:
        with reg.open_registry(path) as conn:
            assert conn.exec_driver_sql("PRAGMA journal_mode").fetchone()[0] == "wal"
            assert reg.schema_version(conn) == reg.SCHEMA_VERSION
    finally:
        timer.join()
        holder.close()
