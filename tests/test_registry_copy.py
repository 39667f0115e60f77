"""`batlab registry copy --from SRC --to DST`: a lab's registry moved into another, SQLite or
PostgreSQL either way, its custody verified on both sides; two labs in one league registry;
refusals that write nothing. Numerics are the test-only stand-ins."""

from __future__ import annotations

import json
import sqlite3

import pytest

from batlab import registry as reg
from tests.inspect_standins import run_cli, stand_in_lab, unchanged_retest


@pytest.fixture
def lab(tmp_path, monkeypatch):
    return stand_in_lab(tmp_path, monkeypatch)


@pytest.fixture(params=["sqlite", "postgresql"])
def dest(request, tmp_path):
    """An empty destination registry: a new SQLite file, or a new database on the server."""
    if request.param == "sqlite":
        return str(tmp_path / "league.sqlite")
    return request.getfixturevalue("pg_url")


def cli(capsys, *args, code=0):
    got, out, err = run_cli(list(args), capsys)
    assert got == code, err
    return out if code == 0 else err


def lab_registry(lab, capsys, db, serial="HX-2001"):
    """A lab's registry: register, inspect the corked re-test, re-register (--replace) with
    another baseline, inspect again; returns its head."""
    meta = json.loads((lab / "meta.json").read_text())
    (lab / f"{serial}.json").write_text(json.dumps({**meta, "serial": serial}))
    register = ["register", "--profile", lab / "profile.csv", "--meta", lab / f"{serial}.json",
                "--db", db]
    cli(capsys, *register, "--baseline", lab / "baseline.uff")
    cli(capsys, "inspect", "--serial", serial, lab / "retest_corked.uff", "--db", db)
    cli(capsys, *register, "--baseline", lab / "retest_corked.uff", "--replace")
    cli(capsys, "inspect", "--serial", serial, lab / "baseline.uff", "--db", db)
    return cli(capsys, "registry", "head", "--db", db).strip()


def history(capsys, db, serial="HX-2001"):
    return json.loads(cli(capsys, "history", serial, "--db", db, "--json"))["inspections"]


def test_copy_moves_a_registry_in_verbatim_and_out_again(lab, capsys, dest, tmp_path):
    src = lab / "reg.sqlite"
    head = lab_registry(lab, capsys, src)
    res = json.loads(cli(capsys, "registry", "copy", "--from", src, "--to", dest, "--json"))
    assert (res["mode"], res["n_bats"], res["n_files"], res["n_inspections"]) == (
        "verbatim", 1, 2, 2)
    assert res["source_head"] == head and res["n_records"] == 6
    assert res["head"].startswith("7:")  # the lab's 6 records, then the signed copy seal
    # the lab's head is still in the destination's chain, record for record
    assert "intact" in cli(capsys, "registry", "check", "--db", dest, "--head", head)
    assert history(capsys, dest) == history(capsys, src)
    with reg.open_registry(dest) as conn:
        seal = reg.custody_rows(conn)[-1]
        assert (seal.kind, seal.subject) == ("seal", "copy")
        assert json.loads(seal.payload)["copied_from"] == head
    # the registry works on: a new inspection gets the next id (a server's id sequence too)
    again = unchanged_retest(lab / "retest_corked.uff", lab / "corked_again.uff")
    new = json.loads(cli(capsys, "inspect", "--serial", "HX-2001", again, "--db", dest,
                         "--json"))
    assert new["status"] == "not_altered"  # a second test of the re-registered baseline
    assert history(capsys, dest)[-1]["id"] == 3
    assert "intact" in cli(capsys, "registry", "check", "--db", dest)
    # copied again: refused, nothing written
    before = cli(capsys, "registry", "head", "--db", dest)
    err = cli(capsys, "registry", "copy", "--from", src, "--to", dest, code=2)
    assert "already holds bat(s) HX-2001" in err and len(err.strip().splitlines()) == 1
    assert cli(capsys, "registry", "head", "--db", dest) == before
    # and out again, into a new file: the same chain, plus the second copy's seal
    back = tmp_path / "back.sqlite"
    res = json.loads(cli(capsys, "registry", "copy", "--from", dest, "--to", back, "--json"))
    assert res["mode"] == "verbatim" and res["n_inspections"] == 3
    assert "intact" in cli(capsys, "registry", "check", "--db", back, "--head", head)
    assert history(capsys, back) == history(capsys, dest)


def test_two_labs_in_one_league_registry(lab, capsys, dest, tmp_path, monkeypatch):
    """Lab A's registry lands verbatim, lab B's (another key, another bat, the same sample
    files) is appended: re-recorded and signed by the league, each copy closed by a seal
    naming the lab's head, which each lab's own registry still proves."""
    keys = {}
    for name in ("a", "b", "league"):
        monkeypatch.setenv("BATLAB_KEY", str(tmp_path / f"{name}.pem"))
        keys[name] = cli(capsys, "registry", "key").strip()
    trust = tmp_path / "labs.txt"
    trust.write_text(f"{keys['a']}\n{keys['b']}\n")
    monkeypatch.setenv("BATLAB_KEY", str(tmp_path / "a.pem"))
    head_a = lab_registry(lab, capsys, lab / "a.sqlite", "HX-2001")
    monkeypatch.setenv("BATLAB_KEY", str(tmp_path / "b.pem"))
    head_b = lab_registry(lab, capsys, lab / "b.sqlite", "HX-2002")
    monkeypatch.setenv("BATLAB_KEY", str(tmp_path / "league.pem"))
    copied = [json.loads(cli(capsys, "registry", "copy", "--from", lab / f"{x}.sqlite", "--to",
                             dest, "--trust", trust, "--json")) for x in "ab"]
    assert [c["mode"] for c in copied] == ["verbatim", "appended"]
    res = json.loads(cli(capsys, "registry", "check", "--db", dest, "--trust", trust,
                         "--trust-own", "--head", head_a, "--json"))  # the league's own too
    assert res["ok"] and res["n_files"] == 2, res["problems"]  # the shared files kept once
    assert res["n_records"] == 6 + 1 + 4 + 1  # A's, a seal, B's 2 + 2 records, a seal
    with reg.open_registry(dest) as conn:
        seals = [json.loads(r.payload) for r in reg.custody_rows(conn) if r.subject == "copy"]
        assert [s["copied_from"] for s in seals] == [head_a, head_b]
        assert [s["source_signers"] for s in seals] == [[keys["a"]], [keys["b"]]]
        signers = {r.signer for r in reg.custody_rows(conn)[7:]}
        assert signers == {keys["league"]}  # B's records re-signed by the league
    for x, serial in (("a", "HX-2001"), ("b", "HX-2002")):
        theirs = history(capsys, lab / f"{x}.sqlite", serial)
        ours = history(capsys, dest, serial)
        assert [h["status"] for h in ours] == [h["status"] for h in theirs]
        assert ours[0]["status"] == "altered" and len(ours) == 2
        assert [h["verdict"] for h in ours] == [h["verdict"] for h in theirs]
    # B's head, anchored in the league's chain, is still B's own head
    assert "intact" in cli(capsys, "registry", "check", "--db", lab / "b.sqlite", "--trust",
                           trust, "--head", seals[1]["copied_from"])
    # trusting the league's key alone, the labs' records do not verify
    code, out, _ = run_cli(["registry", "check", "--db", dest, "--trust-own"], capsys)
    assert code == 1 and f"signed by a key not trusted here ({keys['a']})" in out


def test_copy_refuses_an_unverified_source_and_writes_nothing(lab, capsys, dest):
    src = lab / "reg.sqlite"
    lab_registry(lab, capsys, src)
    with sqlite3.connect(src) as raw:
        raw.execute("UPDATE inspections SET verdict_json = replace(verdict_json, "
                    "'\"altered\": true', '\"altered\": false') WHERE id = 1")
    err = cli(capsys, "registry", "copy", "--from", src, "--to", dest, code=2)
    assert "custody chain does not verify before the copy" in err and "nothing copied" in err
    assert len(err.strip().splitlines()) == 1
    with reg.open_registry(dest) as conn:
        assert reg.list_bats(conn) == [] and reg.custody_rows(conn) == []


def test_a_copy_failing_half_way_leaves_the_destination_as_it_was(lab, capsys, dest,
                                                                    monkeypatch):
    from batlab.registry import copy

    src = lab / "reg.sqlite"
    lab_registry(lab, capsys, src)

    def fail(*args):
        raise OSError("disk full while sealing the copy")

    monkeypatch.setattr(copy, "append_record", fail)  # after every row went in
    err = cli(capsys, "registry", "copy", "--from", src, "--to", dest, code=2)
    assert "disk full" in err
    with reg.open_registry(dest) as conn:
        assert reg.list_bats(conn) == [] and reg.custody_rows(conn) == []
        assert conn.exec_driver_sql("SELECT count(*) FROM files").scalar() == 0
