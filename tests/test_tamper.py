"""Tampering with a registry the lab wrote (through the command line, stand-in numerics),
each on a fresh copy: `batlab registry check` must find every change the threat model
(docs/registry.md) says it finds, name it, and pass the untouched registry, also against the
head printed earlier. Around the file: a foreign SQLite database is refused and left as it
was, a read-only look leaves nothing behind and never reads stale data, and absurd numbers
in the inputs are one line."""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import shutil
import sqlite3
from pathlib import Path

import pytest

from batlab import custody, signing
from tests.inspect_standins import SAMPLE, use_standins


def cli(*args) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of ``batlab args`` in this process."""
    from batlab.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def lab(tmp_path_factory) -> dict:
    """A registry written by the lab: one bat, two inspections with reports; a copy taken
    after the first inspection (for a rollback) and the head printed at the end."""
    root = tmp_path_factory.mktemp("lab")
    for name in ("profile.csv", "meta.json", "baseline.uff", "retest_corked.uff"):
        shutil.copyfile(SAMPLE / name, root / name)
    db = root / "reg.sqlite"
    with pytest.MonkeyPatch.context() as mp:
        use_standins(mp)
        mp.setenv("BATLAB_DB", str(db))
        assert cli("register", "--profile", root / "profile.csv", "--meta",
                   root / "meta.json", "--baseline", root / "baseline.uff")[0] == 0
        for k in (1, 2):
            code, _, err = cli("inspect", "--serial", "HX-2001", root / "retest_corked.uff",
                               "-o", root / f"rep{k}", "--again")  # stored twice
            assert code == 0, err
            if k == 1:
                shutil.copyfile(db, root / "older.sqlite")
        code, head, _ = cli("registry", "head")
    assert code == 0 and re.fullmatch(r"\d+:[0-9a-f]{64}\n", head)
    return {"root": root, "db": db, "head": head.strip(), "older": root / "older.sqlite"}


@pytest.fixture
def copy(lab, tmp_path) -> Path:
    """A fresh copy of the lab's registry."""
    path = tmp_path / "copy.sqlite"
    shutil.copyfile(lab["db"], path)
    return path


def raw(path: Path, *statements: str) -> None:
    conn = sqlite3.connect(path)
    for sql in statements:
        conn.execute(sql)
    conn.commit()
    conn.close()


def check(path: Path, *extra) -> tuple[int, list[str]]:
    """Exit code and the problems of `registry check --json` on ``path`` (the registry's,
    then a checked report page's)."""
    code, out, err = cli("registry", "check", "--db", path, "--json", *extra)
    assert out, err
    res = json.loads(out)
    return code, res["problems"] + (res.get("report") or {}).get("problems", [])


def test_the_lab_registry_checks_clean_also_against_its_head(lab, copy):
    assert check(copy) == (0, [])
    assert check(copy, "--head", lab["head"]) == (0, [])
    code, out, _ = cli("registry", "key")
    assert code == 0 and re.fullmatch(r"ed25519:[A-Za-z0-9+/]{43}=\n", out)


def test_an_edited_verdict_is_found(copy):
    raw(copy, "UPDATE inspections SET status = 'not_altered', verdict_json = "
              "replace(verdict_json, '\"altered\": true', '\"altered\": false') WHERE id = 1")
    code, problems = check(copy)
    assert code == 1 and any("inspection #1: stored verdict differs" in p for p in problems)


def test_deleted_inspection_rows_are_found(copy):
    raw(copy, "DELETE FROM inspections WHERE id = 1")
    code, problems = check(copy)
    assert code == 1
    assert any("inspection #1 is no longer in the registry" in p for p in problems), problems


def test_deleted_inspection_with_its_custody_record_is_found(copy):
    conn = sqlite3.connect(copy)
    seq = conn.execute("SELECT record_seq FROM inspections WHERE id = 1").fetchone()[0]
    conn.close()
    raw(copy, "DELETE FROM inspections WHERE id = 1", f"DELETE FROM custody WHERE seq = {seq}")
    code, problems = check(copy)
    assert code == 1 and any(f"records #{seq}..#{seq} removed" in p for p in problems)


def test_a_deleted_bat_is_found(copy):
    raw(copy, "PRAGMA foreign_keys = OFF", "DELETE FROM inspections", "DELETE FROM stations",
        "DELETE FROM bats")
    code, problems = check(copy)
    assert code == 1 and any("bat 'HX-2001' is no longer in the registry" in p
                             for p in problems)


def test_a_changed_record_seq_is_found(copy):
    raw(copy, "UPDATE inspections SET record_seq = record_seq + 1 WHERE id = 1")
    code, problems = check(copy)
    assert code == 1 and any("inspection #1: names verdict record" in p for p in problems)


def test_renumbered_records_are_found(copy):
    raw(copy, "UPDATE custody SET seq = seq + 1000 WHERE seq = 2")
    code, problems = check(copy)
    assert code == 1 and any("custody record #1002" in p for p in problems), problems


def _other_key(tmp_path, monkeypatch) -> str:
    monkeypatch.setenv("BATLAB_KEY", str(tmp_path / "intruder.pem"))
    return signing.key_id(signing.signing_key().public_key())


def test_a_record_added_with_batlab_and_another_key_is_found(lab, copy, tmp_path,
                                                            monkeypatch):
    """Someone with batlab but not the lab's key stores a new (cleared) verdict."""
    use_standins(monkeypatch)
    lab_key = signing.key_id(signing.signing_key().public_key())
    intruder = _other_key(tmp_path, monkeypatch)
    code, _, err = cli("inspect", "--serial", "HX-2001", lab["root"] / "retest_corked.uff",
                       "--db", copy, "--again")
    assert code == 0, err
    monkeypatch.delenv("BATLAB_KEY")
    code, problems = check(copy, "--trust-own")
    assert code == 1 and any(f"signed by a key not trusted here ({intruder})" in p
                             for p in problems)
    # a league that trusts only the lab's key finds the same; trusting the intruder passes
    (tmp_path / "league.keys").write_text(f"# lab keys\n{lab_key}\n")
    assert check(copy, "--trust", tmp_path / "league.keys")[0] == 1
    (tmp_path / "league.keys").write_text(f"{lab_key}\n{intruder}\n")
    assert check(copy, "--trust", tmp_path / "league.keys") == (0, [])


def _rechain(path: Path, key=None) -> list[tuple]:
    """Re-hash every record in order, each linked to the new hash before it: signed by
    ``key`` (schema 4 rule), or unsigned with the legacy rule when ``key`` is None."""
    conn = sqlite3.connect(path)
    rows = conn.execute("SELECT seq, kind, subject, content_sha256, recorded_at FROM custody "
                        "ORDER BY seq").fetchall()
    prev = custody.GENESIS_SHA256
    for s, kind, subject, content, stamp in rows:
        if key is None:
            new, signer, sig = custody.legacy_record_hash(s, kind, subject, content, prev,
                                                          stamp), None, None
        else:
            signer = signing.key_id(key.public_key())
            data = custody.record_bytes(s, kind, subject, content, prev, stamp, signer)
            new, sig = custody.sha256_text(data.decode()), signing.sign(key, data)
        conn.execute("UPDATE custody SET prev_sha256 = ?, record_sha256 = ?, signer = ?, "
                     "signature = ? WHERE seq = ?", (prev, new, signer, sig, s))
        prev = new
    conn.commit()
    conn.close()
    return rows


def test_a_second_verdict_record_for_an_inspection_is_found(copy, tmp_path, monkeypatch):
    """A cleared verdict appended for inspection #1 (so the latest record would win), signed
    with another key: both the duplicate and the key are named."""
    import batlab.registry as reg

    intruder = _other_key(tmp_path, monkeypatch)
    with reg.open_registry(copy) as conn, reg.transaction(conn):
        payload = reg.chain.inspection_payload(conn, 1)
        seq = reg.chain.append_record(conn, "verdict", "1", None,
                                      reg.chain.canonical({**payload, "status": "not_altered"}))
    monkeypatch.delenv("BATLAB_KEY")
    code, problems = check(copy, "--trust-own")
    assert code == 1
    assert any(f"custody record #{seq} (verdict 1): signed by a key not trusted here "
               f"({intruder})" == p for p in problems), problems
    assert any(p.startswith("inspection #1: 2 verdict records") for p in problems)


def test_a_chain_recomputed_after_an_edit_is_found(copy, tmp_path, monkeypatch):
    """Edit a verdict and its record, then re-hash and re-sign the whole chain with another
    key, or re-hash it unsigned: the signatures say so, record by record."""
    conn = sqlite3.connect(copy)
    seq, payload = conn.execute("SELECT seq, payload FROM custody WHERE seq = (SELECT "
                                "record_seq FROM inspections WHERE id = 1)").fetchone()
    conn.close()
    payload = payload.replace('"status":"altered"', '"status":"not_altered"', 1)
    raw(copy, "UPDATE inspections SET status = 'not_altered' WHERE id = 1",
        "UPDATE custody SET payload = '" + payload.replace("'", "''") + "', content_sha256 = "
        f"'{custody.sha256_text(payload)}' WHERE seq = {seq}")
    key_id = _other_key(tmp_path, monkeypatch)
    rows = _rechain(copy, signing.signing_key())
    monkeypatch.delenv("BATLAB_KEY")
    code, problems = check(copy, "--trust-own")
    assert code == 1 and problems == [
        f"custody record #{s} ({kind} {subject[:16]}): signed by a key not trusted here "
        f"({key_id})" for s, kind, subject, *_ in rows]
    _rechain(copy)
    code, problems = check(copy, "--trust-own")
    assert code == 1 and problems == [
        f"custody record #{s} ({kind} {subject[:16]}): unsigned" for s, kind, subject, *_ in rows]


def test_a_rollback_and_a_truncated_tail_fail_against_the_head(lab, copy):
    code, problems = check(lab["older"], "--head", lab["head"])
    seq = int(lab["head"].split(":")[0])
    assert code == 1 and any(f"record #{seq} is gone" in p for p in problems)
    raw(copy, f"DELETE FROM custody WHERE seq = {seq}",
        "DELETE FROM inspections WHERE id = (SELECT max(id) FROM inspections)")
    assert check(copy) == (0, [])  # without the head a clean cut is invisible
    code, problems = check(copy, "--head", lab["head"])
    assert code == 1 and any("rolled back or truncated" in p for p in problems)


def test_a_report_page_with_edited_verdict_words_fails(lab, copy, tmp_path):
    page = (lab["root"] / "rep2" / "index.html").read_text()
    assert cli("registry", "check", "--db", copy, "--report",
               lab["root"] / "rep2" / "index.html")[0] == 0
    m = re.search(r"<div class='verdict altered'><p>([^<]*)</p>", page)
    assert m and m.group(1).startswith("Altered")
    edited = page.replace(m.group(0), m.group(0).replace(m.group(1), "Not altered."), 1)
    (tmp_path / "edited.html").write_text(edited)
    code, problems = check(copy, "--report", tmp_path / "edited.html")
    assert code == 1 and any("seal does not verify" in p for p in problems)
    # the class too, and the seal removed: the verdict words are checked against the registry
    stripped = re.sub(r'<meta name="batlab-seal"[^>]*>', "", edited).replace(
        "class='verdict altered'", "class='verdict not_altered'")
    (tmp_path / "stripped.html").write_text(stripped)
    code, problems = check(copy, "--report", tmp_path / "stripped.html")
    assert code == 1 and any("carries no seal" in p for p in problems)
    assert any("shows verdict 'not_altered', inspection #2 is 'altered'" in p
               for p in problems), problems
    # the page is blamed, not the registry, and the check says when it ran
    code, out, _ = cli("registry", "check", "--db", copy, "--report",
                       tmp_path / "stripped.html")
    first, *rest = out.splitlines()
    assert code == 1 and ": intact" in first and "DAMAGED" not in out
    page_line = next(line for line in rest if line.startswith(str(tmp_path / "stripped.html")))
    assert "DOES NOT MATCH this registry (the page is at fault" in page_line
    assert re.search(r"checked \d{4}-\d\d-\d\d \d\d:\d\d:\d\d UTC", page_line)


def _schema(path: Path) -> list:
    conn = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
    rows = conn.execute("SELECT type, name, sql FROM sqlite_master ORDER BY name").fetchall()
    conn.close()
    return rows


@pytest.mark.parametrize("args", [
    ["bats"], ["history", "HX-2001"], ["export", "-o", "{tmp}/h.csv"], ["registry", "check"],
    ["registry", "head"], ["report", "HX-2001", "--out", "{tmp}/rep"],
    ["register", "--profile", str(SAMPLE / "profile.csv"), "--meta",
     str(SAMPLE / "meta.json"), "--baseline", str(SAMPLE / "baseline.uff")],
])
def test_a_foreign_database_is_refused_and_left_untouched(tmp_path, args):
    path = tmp_path / "theirs.sqlite"
    raw(path, "CREATE TABLE customers (id INTEGER PRIMARY KEY, name TEXT)",
        "INSERT INTO customers (name) VALUES ('Ada')")
    before, schema = path.read_bytes(), _schema(path)
    code, out, err = cli(*[a.format(tmp=tmp_path) for a in args], "--db", path)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "not a batlab registry" in err and "customers" in err
    assert path.read_bytes() == before and _schema(path) == schema
    assert sorted(p.name for p in tmp_path.iterdir()) == ["theirs.sqlite"]


def test_a_read_only_look_leaves_nothing_and_reads_the_log(lab, tmp_path):
    """A registry copied with its write-ahead log but not its index (a writer still had it
    open): a read command sees the last inspection and leaves no -shm or -wal behind."""
    path = tmp_path / "r.sqlite"
    shutil.copyfile(lab["db"], path)
    writer = sqlite3.connect(path, isolation_level=None)
    writer.execute("PRAGMA wal_autocheckpoint = 0")
    writer.execute("UPDATE inspections SET report_path = 'seen-in-the-log' WHERE id = 2")
    copy = tmp_path / "c" / "r.sqlite"
    copy.parent.mkdir()
    shutil.copyfile(path, copy)
    shutil.copyfile(f"{path}-wal", f"{copy}-wal")
    writer.close()
    code, out, err = cli("history", "HX-2001", "--json", "--db", copy)
    assert code == 0, err
    assert json.loads(out)["inspections"][-1]["report_path"] == "seen-in-the-log"
    assert sorted(p.name for p in copy.parent.iterdir()) == ["r.sqlite", "r.sqlite-wal"]
    clean = tmp_path / "d" / "r.sqlite"
    clean.parent.mkdir()
    shutil.copyfile(lab["db"], clean)
    assert cli("bats", "--db", clean)[0] == 0
    assert [p.name for p in clean.parent.iterdir()] == ["r.sqlite"]


def test_an_infinite_node_number_and_an_absurd_weight_are_one_line(tmp_path):
    uff = (SAMPLE / "baseline.uff").read_bytes()
    node = b"         1         0         0         0  2.54000E-02"
    assert node in uff
    (tmp_path / "inf.uff").write_bytes(uff.replace(node, b"       inf" + node[10:], 1))
    code, out, err = cli("fit", tmp_path / "inf.uff")
    (line,) = [x for x in err.splitlines() if "error" in x]
    assert code == 2 and "Traceback" not in err
    assert "inf.uff" in line and "node records" in line
    meta = json.loads((SAMPLE / "meta.json").read_text())
    meta["weight_lb"] = 1e300
    (tmp_path / "meta.json").write_text(json.dumps(meta))
    code, out, err = cli("model", "--profile", SAMPLE / "profile.csv", "--meta",
                         tmp_path / "meta.json")
    (line,) = [x for x in err.splitlines() if "error" in x]
    assert code == 2 and "Traceback" not in err
    assert "meta.json: key 'weight_lb' = 1e+300 is outside" in line


def test_the_key_is_private_and_announced_once(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "cfg"))
    code, out, err = cli("registry", "key")
    path = tmp_path / "cfg" / "batlab" / "signing-key.pem"
    assert code == 0 and str(path) in err and (path.stat().st_mode & 0o777) == 0o600
    assert cli("registry", "key") == (0, out, "")
    assert not os.environ.get("BATLAB_KEY")
