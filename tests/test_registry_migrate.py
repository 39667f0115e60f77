"""Alembic upgrades a registry in place: one made by the sqlite3 registry of schema 4 (before
SQLAlchemy) keeps every record, its head and its verification, and takes new records."""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

import pytest

from batlab import registry as reg
from batlab import signing

DATA = Path(__file__).with_name("data")
OLD_HEAD = "12:848f383e273fe4fc7e3368ddb726fff41f1ecf5099e935b7d6fa73ec3fb057b3"


@pytest.fixture
def schema4(tmp_path):
    path = tmp_path / "lab.sqlite"
    shutil.copyfile(DATA / "registry_schema4.sqlite", path)
    return path


def trusted() -> set[str]:
    """The schema-4 lab's key and this machine's (which signs the records added here)."""
    signing.signing_key(create=True)
    return signing.trusted_keys(DATA / "registry_schema4.trust", own=True)


def test_schema4_registry_upgrades_in_place_and_keeps_verifying(schema4):
    with sqlite3.connect(schema4) as raw:
        assert raw.execute("SELECT max(version) FROM schema_version").fetchone()[0] == 4
        before = raw.execute("SELECT * FROM custody ORDER BY seq").fetchall()
    with reg.open_registry(schema4) as conn:
        assert reg.schema_version(conn) == reg.SCHEMA_VERSION == 7
        tables = {r[0] for r in conn.exec_driver_sql(
            "SELECT name FROM sqlite_master WHERE type IN ('table', 'index')")}
        assert "schema_version" not in tables and "inspections_by_record" in tables
        assert conn.exec_driver_sql("SELECT version_num FROM alembic_version").all() == [
            ("0007",)]
        assert conn.exec_driver_sql("SELECT * FROM custody ORDER BY seq").all() == before
        res = reg.check(conn, trusted(), OLD_HEAD)
        assert res.ok and res.head == OLD_HEAD, res.problems
        assert [i.status for i in reg.all_inspections(conn)] == [
            "not_altered", "altered", "inconclusive"]
        first = reg.history(conn, "S4-1")[0]
        assert reg.bat_as_registered(conn, first.reference_seq).baseline_name == "base1.uff"
        assert reg.get_bat(conn, "S4-1").baseline_name == "base1b.uff"
        new = reg.add_inspection(conn, "S4-2", {"altered": True}, "r4.uff", b"retest four")
        assert new.id == 4 and new.record_seq == 14  # after its re-test file's record #13
        assert reg.check(conn, trusted(), OLD_HEAD).ok


def test_upgrade_is_one_transaction(schema4, monkeypatch):
    """A migration that fails half-way leaves the schema-4 file as it was."""
    from batlab.registry import migration

    def broken(conn, version, target):
        conn.exec_driver_sql("DROP TABLE schema_version")
        raise RuntimeError("migration failed half-way")

    monkeypatch.setattr(migration, "_alembic", broken)
    with pytest.raises(RuntimeError, match="half-way"):
        reg.connect(schema4)
    with sqlite3.connect(schema4) as raw:
        assert raw.execute("SELECT max(version) FROM schema_version").fetchone()[0] == 4


def test_reading_a_schema4_registry_upgrades_it_once(schema4):
    """`batlab bats` (a read-only opening) on a writable schema-4 file migrates it first."""
    with reg.open_registry(schema4, create=False, readonly=True) as conn:
        assert [b.serial for b in reg.list_bats(conn)] == ["S4-1", "S4-2"]
        assert reg.schema_version(conn) == 7
    with sqlite3.connect(schema4) as raw:
        assert raw.execute("SELECT version_num FROM alembic_version").fetchall() == [("0007",)]
