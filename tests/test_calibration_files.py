"""Calibrations bound to their statistic and travelling as signed files (stand-in numerics):
an inspection against a calibration of another version of F says unmeasured, with the
reason; `registry calibrations` lists the versions; a calibration exported from one registry
and imported into another states the same chance; a tampered export, or one signed by a key
not trusted, is refused and nothing stored; batlab's shipped calibrations are read from their
place and only under a listed key."""

from __future__ import annotations

import json

import pytest

from batlab import registry as reg
from batlab import signing
from batlab.registry.calibration_files import shipped_calibration
from tests.inspect_standins import run_cli, stand_in_lab
from tests.test_calibrations import sample_model, stand_in_F, stateless, store
from updating.inspect import nested


@pytest.fixture
def lab(tmp_path, monkeypatch):
    return stand_in_lab(tmp_path, monkeypatch)


def chance(lab, capsys, db) -> dict:
    code, out, err = run_cli(stateless(lab, "--db", db, "--json"), capsys)
    assert code == 0, err
    return json.loads(out)["chance"]


def test_a_calibration_of_another_version_is_not_used(lab, capsys, monkeypatch):
    db = lab / "reg.sqlite"
    stored = store(db, [0.5, 1.5, 7.0])
    assert stored.statistic_version == nested.STATISTIC_VERSION
    got = chance(lab, capsys, db)
    assert got["source"] == "calibration"
    assert got["calibration"]["statistic_version"] == nested.STATISTIC_VERSION
    now = nested.STATISTIC_VERSION + 1  # a release whose F is defined otherwise
    monkeypatch.setattr(nested, "STATISTIC_VERSION", now)
    got = chance(lab, capsys, db)
    assert got["source"] == "nominal" and got["calibration"] is None
    assert got["unmeasured"] == (f"the stored calibration measured F version {now - 1}, this "
                                 f"release computes version {now}: re-run fleet calibrate")
    code, out, _ = run_cli(["registry", "calibrations", "--json"], capsys)
    assert code == 0 and json.loads(out)[0]["statistic_version"] == now - 1
    code, out, _ = run_cli(["registry", "calibrations"], capsys)
    assert f"F version {now - 1}" in out


def test_a_calibration_stored_before_versions_is_not_used(lab, capsys):
    db = lab / "reg.sqlite"
    with reg.open_registry(db) as conn:  # as schema 6 stored it: no version
        old = reg.add_calibration(conn, sample_model(), 2, 0, 0.78, "F", {}, {"F": [1.0, 2.0]},
                                  "0.1", None)
        assert "statistic_version" not in json.loads(reg.custody_rows(conn)[-1].payload)
        assert reg.check(conn).ok and old.statistic_version is None
    got = chance(lab, capsys, db)
    assert got["source"] == "nominal" and got["unmeasured"].startswith(
        "the stored calibration measured F an unknown version (stored before versions")


def test_an_exported_calibration_imported_elsewhere_gives_the_same_chance(
        lab, capsys, tmp_path, monkeypatch):
    """The league calibrates and exports with its key; the lab imports it trusting that key:
    the same chance, n and exceedances; the import is a custody record naming the signer."""
    stand_in_F(lab, capsys)  # a registered bat in the lab's registry
    league_db = tmp_path / "league.sqlite"
    monkeypatch.setenv("BATLAB_KEY", str(tmp_path / "league.pem"))
    store(league_db, [0.5, 1.5, 7.0, None, 3.0, 1e3])
    league = signing.key_id(signing.signing_key().public_key())
    exported = tmp_path / "cal.json"
    code, out, err = run_cli(["registry", "calibrations", "--db", league_db, "--export",
                              exported], capsys)
    assert code == 0 and f"signed by {league}" in out, err
    monkeypatch.delenv("BATLAB_KEY")  # back at the lab
    lab_db = lab / "reg.sqlite"
    trust = tmp_path / "league.keys"
    trust.write_text(f"{league}\n")
    code, out, err = run_cli(["registry", "calibrations", "--db", lab_db, "--import",
                              exported, "--trust", trust], capsys)
    assert code == 0 and f"signed by {league}" in out, err
    theirs, ours = chance(lab, capsys, league_db), chance(lab, capsys, lab_db)
    assert ours["source"] == "calibration" and ours["value"] == theirs["value"]
    for k in ("n", "exceeding", "false_alarms", "false_alarm_upper95", "statistic_version"):
        assert ours["calibration"][k] == theirs["calibration"][k]
    assert ours["calibration"]["signer"] == league
    with reg.open_registry(lab_db, create=False) as conn:
        record = json.loads(reg.custody_rows(conn)[-1].payload)
        assert record["origin"]["signer"] == league and reg.check(conn).ok
    # re-exported by the lab, the file keeps the league's signature
    again = tmp_path / "again.json"
    assert run_cli(["registry", "calibrations", "--db", lab_db, "--export", again],
                   capsys)[0] == 0
    assert json.loads(again.read_text()) == json.loads(exported.read_text())
    # a key record revoking the league's key: the calibration is no longer used
    code, _, err = run_cli(["registry", "key", "--revoke", league, "--db", lab_db], capsys)
    assert code == 0, err
    got = chance(lab, capsys, lab_db)
    assert got["source"] == "nominal" and "revoked by record #" in got["unmeasured"]


def test_a_tampered_or_untrusted_export_is_refused(lab, capsys, tmp_path):
    db = lab / "reg.sqlite"
    store(db, [0.5, 1.5, 7.0])
    exported = tmp_path / "cal.json"
    assert run_cli(["registry", "calibrations", "--export", exported], capsys)[0] == 0
    other = tmp_path / "other.sqlite"
    doc = json.loads(exported.read_text())
    doc["calibration"]["null"]["F"][2] = 0.7  # a clean re-test's F made smaller
    (tmp_path / "tampered.json").write_text(json.dumps(doc))
    for args, said in (
            (["--import", tmp_path / "tampered.json", "--trust-own"],
             "its signature does not verify for key"),
            (["--import", exported], "a key not trusted here"),
            (["--import", tmp_path / "missing.json", "--trust-own"], "cannot read")):
        code, out, err = run_cli(["registry", "calibrations", "--db", other, *args], capsys)
        assert code == 2 and said in err and len(err.strip().splitlines()) == 1, err
    with reg.open_registry(other) as conn:
        assert reg.list_calibrations(conn) == []
    code, _, err = run_cli(["registry", "calibrations", "--db", other, "--import", exported,
                            "--trust-own"], capsys)
    assert code == 0, err
    # an imported calibration's row changed together with its record (re-signed by the lab):
    # the league's signature no longer verifies for it
    import sqlite3

    from batlab import custody

    raw = sqlite3.connect(other)
    seq, payload = raw.execute("SELECT seq, payload FROM custody WHERE kind = 'calibration'"
                               ).fetchone()
    raw.execute("UPDATE calibrations SET n = 30")
    changed = payload.replace('"n":3,', '"n":30,', 1)
    raw.execute("UPDATE custody SET payload = ?, content_sha256 = ? WHERE seq = ?",
                (changed, custody.sha256_text(changed), seq))
    raw.commit()
    raw.close()
    from tests.test_trust import rechain

    rechain(other, signing.signing_key(), seq)
    code, out, _ = run_cli(["registry", "check", "--db", other, "--json"], capsys)
    assert code == 1 and json.loads(out)["problems"] == [
        f"calibration #1 ({sample_model()}): imported, but its signature by "
        f"{signing.key_id(signing.signing_key().public_key())} does not verify for what is "
        "stored"]


def test_a_shipped_calibration_is_read_from_its_place_under_a_listed_key(
        lab, capsys, tmp_path, monkeypatch):
    """The place batlab ships calibrations (a signed file a model, signers.keys): used when
    the registry holds none of the bat's model; a file signed by an unlisted key is a broken
    install, said in one line."""
    db = lab / "reg.sqlite"
    store(db, [0.5, 1.5, 7.0, 2.0])
    shipped = tmp_path / "shipped"
    shipped.mkdir()
    model = sample_model()
    assert run_cli(["registry", "calibrations", "--export", shipped / f"{model}.json"],
                   capsys)[0] == 0
    (shipped / "signers.keys").write_text("# release key\n")
    with pytest.raises(ValueError, match="not a key in"):
        shipped_calibration(model, shipped)
    (shipped / "signers.keys").write_text(signing.key_id(signing.signing_key().public_key()))
    got = shipped_calibration(model, shipped)
    assert got.n == 4 and got.origin["shipped"] and shipped_calibration("other", shipped) is None
    monkeypatch.setattr("batlab.registry.calibration_files.SHIPPED_DIR", shipped)
    expected = chance(lab, capsys, db)
    empty = tmp_path / "empty.sqlite"  # a registry holding no calibration
    reg.connect(empty).close()
    (shipped / "signers.keys").write_text("# nobody\n")  # a broken install: unmeasured, why
    got = chance(lab, capsys, empty)
    assert got["source"] == "nominal" and got["unmeasured"].startswith(
        "batlab's shipped calibration was refused: ") and "not a key in" in got["unmeasured"]
    (shipped / "signers.keys").write_text(signing.key_id(signing.signing_key().public_key()))
    got = chance(lab, capsys, empty)
    assert got["source"] == "calibration" and got["calibration"]["shipped"]
    assert got["value"] == expected["value"] and got["calibration"]["record_seq"] is None
