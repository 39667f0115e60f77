"""Trust that holds (docs/registry.md): `registry check` trusts exactly the keys it is given;
keys are handed over (`registry key --rotate`) and revoked (`--revoke`) by custody records;
heads are witnessed (`registry head --json`, `registry witness`) and `check --witnessed`
proves a registry extends them, naming the first record that differs, and tells forks apart.
Registries written through the library (no numerics), each with its own throw-away keys."""

from __future__ import annotations

import contextlib
import io
import json
import sqlite3
from pathlib import Path

import pytest

import batlab.registry as reg
from batlab import custody, signing


def cli(*args) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of ``batlab args`` in this process."""
    from batlab.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


def use_key(monkeypatch, path: Path) -> str:
    """Sign with the key in ``path`` (made if need be); return its id."""
    monkeypatch.setenv("BATLAB_KEY", str(path))
    return signing.key_id(signing.signing_key(create=True).public_key())


def make_bat(serial: str) -> reg.BatRecord:
    return reg.BatRecord(serial=serial, profile_x_m=[0.0, 0.4, 0.86],
                         profile_diameter_m=[0.03, 0.035, 0.066], meta={"serial": serial},
                         species="maple", reference={"E_pa": 1.2e10}, modes={"freq_hz": [1.0]})


def write(db: Path, serial: str, n_inspections: int = 1) -> None:
    """Register a bat and store inspections of it, signed by the current key."""
    with reg.open_registry(db) as conn:
        if not reg.has_bat(conn, serial):
            reg.add_bat(conn, make_bat(serial), f"{serial}.uff", f"base {serial}".encode())
        for k in range(n_inspections):
            n = len(reg.history(conn, serial))
            reg.add_inspection(conn, serial, {"altered": k % 2 == 0}, f"r{n}.uff",
                               f"retest {serial} {n}".encode())


def check(db: Path, *extra) -> tuple[int, dict]:
    code, out, err = cli("registry", "check", "--db", db, "--json", *extra)
    assert out, err
    return code, json.loads(out)


def keys_file(path: Path, *keys: str) -> Path:
    path.write_text("# lab keys\n" + "".join(k + "\n" for k in keys))
    return path


def rechain(db: Path, key, start: int = 1) -> None:
    """Re-hash and re-sign every record from ``start`` on with ``key``, each linked to the
    new hash before it (a rewrite by whoever holds ``key``)."""
    conn = sqlite3.connect(db)
    rows = conn.execute("SELECT seq, kind, subject, content_sha256, recorded_at, prev_sha256 "
                        "FROM custody ORDER BY seq").fetchall()
    prev = rows[start - 1][5]
    signer = signing.key_id(key.public_key())
    for s, kind, subject, content, stamp, _ in rows[start - 1:]:
        data = custody.record_bytes(s, kind, subject, content, prev, stamp, signer)
        new = custody.sha256_text(data.decode())
        conn.execute("UPDATE custody SET prev_sha256 = ?, record_sha256 = ?, signer = ?, "
                     "signature = ? WHERE seq = ?", (prev, new, signer,
                                                      signing.sign(key, data), s))
        prev = new
    conn.commit()
    conn.close()


def test_a_registry_resigned_whole_with_a_second_key_fails_against_the_lab_keys(
        tmp_path, monkeypatch):
    """On a machine holding the second key: `--trust lab.keys` names every record; without
    --trust the check passes but says it checked consistency, not who signed; that machine's
    own key is trusted only when asked (`--trust-own`)."""
    db = tmp_path / "lab.sqlite"
    lab = use_key(monkeypatch, tmp_path / "lab.pem")
    write(db, "T1", 2)
    trust = keys_file(tmp_path / "lab.keys", lab)
    assert check(db, "--trust", trust)[0] == 0
    other = use_key(monkeypatch, tmp_path / "other.pem")  # the checking machine's key
    rechain(db, signing.signing_key())
    code, res = check(db, "--trust", trust)
    assert code == 1 and len(res["problems"]) == res["n_records"] == 6
    assert all(p.endswith(f"signed by a key not trusted here ({other})")
               for p in res["problems"]), res["problems"]
    code, res = check(db)
    assert code == 0 and res["notes"][-1].startswith(
        "no --trust given: the signatures were checked for consistency only")
    assert f"signed by {other} (fingerprint {signing.fingerprint(other)}, records #1..#6)" \
        in res["notes"][-1]
    assert res["signers_checked"] is False and check(db, "--trust", trust)[1]["signers_checked"]
    code, out, _ = cli("registry", "check", "--db", db)
    assert code == 0 and "consistency only" in out and "not who signed" in out
    assert out.splitlines()[0].endswith(": intact (signatures consistent; who signed was not "
                                        "checked: give --trust KEYS or --trust-own): 6 custody "
                                        "records, 3 files")
    assert check(db, "--trust-own")[0] == 0  # asked for: the machine's own key
    assert check(db, "--trust-own", "--trust", trust)[0] == 0


def test_after_a_rotation_the_old_key_alone_is_trusted_and_retired(tmp_path, monkeypatch):
    """The handover record is signed by both keys; a check trusting only the old key follows
    it; the old key (stolen, say) signing after the handover fails, trusted or not."""
    db = tmp_path / "lab.sqlite"
    key_path = tmp_path / "lab.pem"
    old = use_key(monkeypatch, key_path)
    write(db, "T1")
    code, out, err = cli("registry", "key", "--rotate", "--db", db)
    assert code == 0, err
    new = out.strip()
    assert new != old and new == signing.key_id(signing.signing_key().public_key())
    retired = tmp_path / f"lab.pem.retired-{signing.fingerprint(old)}.pem"
    assert retired.exists() and f"handed over to {new}" in err
    with reg.open_registry(db) as conn:
        handover = reg.custody_rows(conn)[-1]
    payload = json.loads(handover.payload)
    assert handover.kind == "key" and handover.signer == old and payload["new"] == new
    write(db, "T1")  # signed by the new key
    old_keys = keys_file(tmp_path / "old.keys", old)
    code, res = check(db, "--trust", old_keys)
    assert code == 0, res["problems"]
    # the new key signed the handover: trusting it alone covers the old key's records before
    assert check(db, "--trust", keys_file(tmp_path / "new.keys", new))[0] == 0
    assert check(db, "--trust-own")[0] == 0  # the lab's machine, holding the new key
    _, stranger = league_key(tmp_path)  # a key in no handover: nothing it signed
    assert check(db, "--trust", keys_file(tmp_path / "stranger.keys", stranger))[0] == 1
    # the old key, kept or stolen, signs again: refused from the handover on
    with reg.open_registry(db) as conn, reg.transaction(conn):
        seq = reg.chain.append_record(conn, "seal", "forged", None, "{}",
                                      key=signing.load_key(retired))
    for extra in ((), ("--trust", old_keys)):
        code, res = check(db, *extra)
        assert code == 1 and res["problems"] == [
            f"custody record #{seq} (seal forged): signed by key {old}, retired by handover "
            f"record #{handover.seq}"]


def test_a_handover_not_signed_by_the_new_key_fails(tmp_path, monkeypatch):
    db = tmp_path / "lab.sqlite"
    use_key(monkeypatch, tmp_path / "lab.pem")
    write(db, "T1")
    assert cli("registry", "key", "--rotate", "--db", db)[0] == 0
    conn = sqlite3.connect(db)
    seq, payload = conn.execute("SELECT seq, payload FROM custody WHERE kind = 'key'"
                                ).fetchone()
    conn.close()
    p = json.loads(payload)
    thief = use_key(monkeypatch, tmp_path / "thief.pem")
    forged = custody.canonical({**p, "new": thief})
    conn = sqlite3.connect(db)
    conn.execute("UPDATE custody SET payload = ?, content_sha256 = ? WHERE seq = ?",
                 (forged, custody.sha256_text(forged), seq))
    conn.commit()
    conn.close()
    rechain(db, signing.load_key(tmp_path / f"lab.pem.retired-{signing.fingerprint(p['old'])}"
                                 ".pem"), seq)  # the old key re-signs it: still not the new's
    code, res = check(db)
    assert code == 1 and f"custody record #{seq} (key rotate): the new key's signature does " \
        f"not verify ({thief})" in res["problems"]


def test_after_a_revocation_a_later_record_by_the_revoked_key_fails(tmp_path, monkeypatch):
    """A league's registry with a second lab's records: the league revokes that lab's key (by
    its fingerprint); the records signed before stay good, one signed after fails."""
    db = tmp_path / "league.sqlite"
    league = use_key(monkeypatch, tmp_path / "league.pem")
    write(db, "L1")
    lab2 = use_key(monkeypatch, tmp_path / "lab2.pem")
    write(db, "L2")
    use_key(monkeypatch, tmp_path / "league.pem")
    trust = keys_file(tmp_path / "all.keys", league, lab2)
    assert check(db, "--trust", trust)[0] == 0
    code, out, err = cli("registry", "key", "--revoke", signing.fingerprint(lab2), "--db", db)
    assert code == 0 and f"key {lab2} revoked" in out, err
    assert check(db, "--trust", trust)[0] == 0  # the earlier records stay good
    use_key(monkeypatch, tmp_path / "lab2.pem")
    write(db, "L2")  # after its revocation: file record and verdict record
    for extra in ((), ("--trust", trust)):
        code, res = check(db, *extra)
        assert code == 1 and len(res["problems"]) == 2
        assert all(f"signed by key {lab2}, revoked by record #" in p for p in res["problems"])
    use_key(monkeypatch, tmp_path / "league.pem")
    code, _, err = cli("registry", "key", "--revoke", league, "--db", db)
    assert code == 2 and "--rotate` first" in err  # a lab cannot revoke the key it signs with
    code, _, err = cli("registry", "key", "--revoke", "00000000", "--db", db)
    assert code == 2 and "names no key that signed this registry" in err


def witnessed(db: Path, tmp_path: Path, name: str, league_pem: Path) -> Path:
    """The lab's head statement, countersigned by the league: the witnessed file."""
    code, out, err = cli("registry", "head", "--db", db, "--json")
    assert code == 0, err
    head = tmp_path / f"{name}.head.json"
    head.write_text(out)
    done = tmp_path / f"{name}.witnessed.json"
    code, _, err = cli("registry", "witness", head, "--key", league_pem, "-o", done)
    assert code == 0, err
    return done


def league_key(tmp_path: Path) -> tuple[Path, str]:
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

    key = Ed25519PrivateKey.generate()
    tmp_path.mkdir(exist_ok=True)
    signing.write_key(tmp_path / "league.pem", key)
    return tmp_path / "league.pem", signing.key_id(key.public_key())


def test_the_head_statement_is_signed_by_the_lab(tmp_path, monkeypatch):
    db = tmp_path / "lab.sqlite"
    lab = use_key(monkeypatch, tmp_path / "lab.pem")
    write(db, "W1")
    code, out, _ = cli("registry", "head", "--db", db, "--json")
    stmt = json.loads(out)
    _, line, _ = cli("registry", "head", "--db", db)
    assert code == 0 and f"{stmt['seq']}:{stmt['sha256']}" == line.strip()
    assert stmt["lab_key"] == lab and stmt["time"] and stmt["record"]["signer"] == lab
    assert len(stmt["record_hashes"]) == 16 * stmt["seq"]
    assert reg.witness.statement_problem(stmt) is None
    bad = {**stmt, "sha256": "0" * 64}
    assert reg.witness.statement_problem(bad) == "its record does not hash to its head"
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    pem, _ = league_key(tmp_path)
    code, _, err = cli("registry", "witness", tmp_path / "bad.json", "--key", pem, "-o",
                       tmp_path / "w.json")
    assert code == 2 and "nothing witnessed" in err and not (tmp_path / "w.json").exists()
    (tmp_path / "head.json").write_text(out)
    code, _, err = cli("registry", "witness", tmp_path / "head.json", "--key", pem, "--trust",
                       keys_file(tmp_path / "other.keys", league_key(tmp_path / "x")[1]))
    assert code == 2 and f"a head of key {lab}, not one of the lab keys trusted" in err
    code, out, err = cli("registry", "witness", tmp_path / "head.json", "--key", pem,
                         "--trust", keys_file(tmp_path / "lab.keys", lab))
    assert code == 0 and json.loads(out)["head"] == stmt, err


def test_a_history_rewritten_after_a_witnessed_head_fails_naming_the_first_record(
        tmp_path, monkeypatch):
    """The lab's own key (stolen) rewrites a verdict written before the witnessed head and
    re-signs everything after it: `--trust lab.keys` passes, `--witnessed` fails and names
    the verdict's record."""
    db = tmp_path / "lab.sqlite"
    lab = use_key(monkeypatch, tmp_path / "lab.pem")
    write(db, "W1", 3)
    pem, league = league_key(tmp_path)
    seen = witnessed(db, tmp_path, "monday", pem)
    write(db, "W1")  # the lab goes on: the registry extends the head
    trust = keys_file(tmp_path / "lab.keys", lab, league)
    code, res = check(db, "--trust", trust, "--witnessed", seen)
    assert code == 0 and any("the registry extends it (records #1..#" in n
                             for n in res["notes"]), res
    conn = sqlite3.connect(db)
    seq, payload = conn.execute("SELECT record_seq, c.payload FROM inspections i JOIN custody "
                                "c ON c.seq = i.record_seq WHERE i.id = 2").fetchone()
    conn.close()
    edited = payload.replace('"status":"not_altered"', '"status":"altered"', 1)
    assert edited != payload
    conn = sqlite3.connect(db)
    conn.execute("UPDATE inspections SET status = 'altered' WHERE id = 2")
    conn.execute("UPDATE custody SET payload = ?, content_sha256 = ? WHERE seq = ?",
                 (edited, custody.sha256_text(edited), seq))
    conn.commit()
    conn.close()
    rechain(db, signing.load_key(tmp_path / "lab.pem"), seq)
    assert check(db, "--trust", trust)[0] == 0  # the real key signed it all
    code, res = check(db, "--trust", trust, "--witnessed", seen)
    assert code == 1 and len(res["problems"]) == 1
    assert f"the registry does not extend it: record #{seq} is the first that differs" in \
        res["problems"][0] and str(seen) in res["problems"][0]
    assert res["first_changed"] == seq
    # a witness not in --trust, or a witnessed file changed afterwards, is named
    code, res = check(db, "--trust", keys_file(tmp_path / "only.keys", lab), "--witnessed",
                      seen)
    assert code == 1 and f"witnessed by a key not trusted here ({league})" in \
        res["problems"][0]
    w = json.loads(seen.read_text())
    w["witnessed_at"] = "2020-01-01T00:00:00+00:00"
    (tmp_path / "changed.json").write_text(json.dumps(w))
    code, res = check(db, "--witnessed", tmp_path / "changed.json")
    assert code == 1 and "the witness's signature does not verify" in res["problems"][0]


def test_two_forks_from_one_key_are_told_apart(tmp_path, monkeypatch):
    """One lab key, two histories from record #n on (the registry copied and written on
    twice): both heads witnessed; a check given both names the fork and the head the
    registry does not extend."""
    import shutil

    a, b = tmp_path / "a.sqlite", tmp_path / "b.sqlite"
    use_key(monkeypatch, tmp_path / "lab.pem")
    write(a, "F1", 2)
    shutil.copyfile(a, b)
    with reg.open_registry(a) as conn:
        n = len(reg.custody_rows(conn)) + 1
    write(a, "F1")
    write(b, "F1", 2)  # another re-test first: the two differ from record #n on
    pem, _ = league_key(tmp_path)
    wa, wb = witnessed(a, tmp_path, "a", pem), witnessed(b, tmp_path, "b", pem)
    assert check(a, "--witnessed", wa)[0] == 0 and check(b, "--witnessed", wb)[0] == 0
    code, res = check(a, "--witnessed", wa, wb)
    assert code == 1 and len(res["problems"]) == 2, res["problems"]
    assert f"{wb}" in res["problems"][0] and f"record #{n} is the first that differs" in \
        res["problems"][0]
    assert res["problems"][1].startswith("fork: ") and "two histories signed by one key" in \
        res["problems"][1] and res["problems"][1].endswith(f"differ from record #{n} on")


@pytest.mark.parametrize("damage", ["not json", '{"format": "other"}'])
def test_an_unreadable_witnessed_file_is_one_line(tmp_path, monkeypatch, damage):
    db = tmp_path / "lab.sqlite"
    use_key(monkeypatch, tmp_path / "lab.pem")
    write(db, "W1")
    (tmp_path / "w.json").write_text(damage)
    code, out, err = cli("registry", "check", "--db", db, "--witnessed", tmp_path / "w.json")
    assert code == 2 and not out and str(tmp_path / "w.json") in err
    assert len(err.strip().splitlines()) == 1


def test_a_postgresql_registry_of_schema_6_takes_key_records(pg_url, tmp_path, monkeypatch):
    """Taken back to schema 6's layout (custody's kind check without 'key', calibrations
    without a version or origin), a server registry is upgraded in place, keeps verifying,
    and takes a handover record."""
    old = use_key(monkeypatch, tmp_path / "lab.pem")
    with reg.open_registry(pg_url) as conn:
        reg.add_bat(conn, make_bat("P1"), "P1.uff", b"base P1")
        reg.add_calibration(conn, "m", 2, 0, 0.78, "F", {}, {"F": [1.0, 2.0]}, "0.1", None)
        conn.exec_driver_sql("ALTER TABLE calibrations DROP COLUMN statistic_version")
        conn.exec_driver_sql("ALTER TABLE calibrations DROP COLUMN origin_json")
        conn.exec_driver_sql("ALTER TABLE custody DROP CONSTRAINT custody_kind")
        conn.exec_driver_sql("ALTER TABLE custody ADD CONSTRAINT custody_kind CHECK (kind IN "
                             "('file', 'reference', 'verdict', 'seal', 'calibration'))")
        conn.exec_driver_sql("UPDATE alembic_version SET version_num = '0006'")
        conn.commit()
    with reg.open_registry(pg_url) as conn:
        assert reg.schema_version(conn) == 7 and reg.check(conn, {old}).ok
        change = reg.rotate_key(conn)
        assert reg.custody_rows(conn)[-1].kind == "key" and change.old == old
        reg.add_inspection(conn, "P1", {"altered": False}, "r.uff", b"retest P1")
        res = reg.check(conn, {old})
        assert res.ok, res.problems


def test_a_handover_of_the_lab_key_signed_by_another_fails(tmp_path, monkeypatch):
    """Without the lab's key, an intruder appends a handover from it to a key of its own
    (signed by the intruder's key, the new key's signature valid): named, and the intruder's
    later records stay untrusted."""
    from batlab import custody_keys

    db = tmp_path / "lab.sqlite"
    lab = use_key(monkeypatch, tmp_path / "lab.pem")
    write(db, "T1")
    intruder = use_key(monkeypatch, tmp_path / "intruder.pem")
    key = signing.signing_key()
    with reg.open_registry(db) as conn, reg.transaction(conn):
        seq, prev = reg.chain.next_record(conn)
        payload = {**custody_keys.handover_payload(seq, prev, lab, key), "old": lab}
        reg.chain.append_record(conn, "key", "rotate", None, custody.canonical(payload))
    write(db, "T1")
    code, res = check(db, "--trust", keys_file(tmp_path / "lab.keys", lab))
    assert code == 1 and res["problems"][0] == (
        f"custody record #{seq} (key rotate): signed by a key not trusted here ({intruder})")
    code, res = check(db)  # consistency alone: the handover names a key that did not sign it
    assert code == 1 and res["problems"] == [
        f"custody record #{seq} (key rotate): hands over key {lab}, but is signed by "
        f"{intruder}"]
