"""The registry from the command line: a past report rebuilt from the registry alone, the
history as CSV, `registry check`, and one-line errors for unwritable, damaged and read-only
registries; the verdict is stored and printed before the report can fail."""

from __future__ import annotations

import json
import os
import re
import shutil
import sqlite3

import pandas as pd
import pytest

from tests.inspect_standins import SAMPLE, run_cli, stand_in_lab, unchanged_retest

DATE_LINE = re.compile(r"<tr><td>Report generated \(UTC\)</td><td>[^<]*</td></tr>")
# what a rebuilt page may change besides its date: the head it was written at and its seal
WRITTEN = re.compile(r"<tr><td>Registry head when written</td><td><code>[^<]*</code></td></tr>"
                     r'|<meta name="batlab-seal" content="[^"]*">')


@pytest.fixture
def lab(tmp_path, monkeypatch):
    return stand_in_lab(tmp_path, monkeypatch)


def register(lab, capsys, extra=()):
    code, _, err = run_cli(["register", "--profile", lab / "profile.csv", "--meta",
                            lab / "meta.json", "--baseline", lab / "baseline.uff", *extra],
                           capsys)
    assert code == 0, err


def test_report_regenerated_from_the_registry_alone(lab, capsys):
    """register, inspect with a report, delete the re-test file, re-register the bat with
    another baseline (--replace): `batlab report` rebuilds the first page byte for byte apart
    from its date, against the registration it was judged with."""
    register(lab, capsys)
    retest = lab / "retest_corked.uff"
    code, out, _ = run_cli(["inspect", "--serial", "HX-2001", retest, "-o",
                            lab / "rep", "--json"], capsys)
    assert code == 0 and json.loads(out)["altered"] is True
    original = (lab / "rep" / "index.html").read_text()
    retest.unlink()
    shutil.copyfile(SAMPLE / "retest_corked.uff", lab / "baseline.uff")
    register(lab, capsys, ["--replace"])
    code, out, err = run_cli(["report", "HX-2001", "--inspection", "1", "--out", lab / "again",
                              "--plots", lab / "plots"], capsys)
    assert code == 0, err
    assert out.strip() == str(lab / "again" / "index.html")
    again = (lab / "again" / "index.html").read_text()
    assert len(DATE_LINE.findall(original)) == 1
    assert len(WRITTEN.findall(original)) == 2
    assert WRITTEN.sub("", DATE_LINE.sub("", again)) == WRITTEN.sub("", DATE_LINE.sub("", original))
    assert again != original or DATE_LINE.search(again)  # only the date may differ
    assert (lab / "plots" / "elements.png").is_file()
    # the bat's first inspection is its inspection 1, whatever the registry's numbering
    assert re.search(r"inspection <span class='n'>1</span> of bat HX-2001, \S+ \(registry "
                     r"inspection #\d+\)", again)
    code, out, _ = run_cli(["history", "HX-2001", "--json"], capsys)
    (insp,) = json.loads(out)["inspections"]
    assert insp["record_sha256"] in again and insp["retest_sha256"] in again
    assert insp["report_path"] == str(lab / "rep" / "index.html")
    # the report verifies against the registry; a forged one does not
    code, out, _ = run_cli(["registry", "check", "--report", lab / "again" / "index.html"],
                           capsys)
    assert code == 0 and "intact" in out
    assert f"{lab / 'again' / 'index.html'}: verified against this registry, checked " in out
    forged = again.replace(insp["record_sha256"], "0" * 64)
    (lab / "forged.html").write_text(forged)
    code, out, _ = run_cli(["registry", "check", "--report", lab / "forged.html"], capsys)
    assert code == 1 and f"custody record #{insp['record_seq']} has hash" in out


def test_report_of_an_unknown_inspection(lab, capsys):
    register(lab, capsys)
    code, out, err = run_cli(["report", "HX-2001", "--out", lab / "r"], capsys)
    assert code == 2 and out == "" and "has no inspection" in err
    assert run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff"], capsys)[0] == 0
    code, _, err = run_cli(["report", "HX-2001", "--inspection", "7", "--out", lab / "r"],
                           capsys)
    assert code == 2 and "inspection #7" in err


def test_export_csv(lab, capsys):
    register(lab, capsys)
    unchanged_retest(SAMPLE / "baseline.uff", lab / "retest_same.uff")  # an unchanged bat
    for name in ("retest_corked.uff", "retest_same.uff"):
        assert run_cli(["inspect", "--serial", "HX-2001", lab / name], capsys)[0] == 0
    code, out, _ = run_cli(["export", "HX-2001", "-o", lab / "h.csv"], capsys)
    assert code == 0 and "2 inspection(s)" in out
    table = pd.read_csv(lab / "h.csv")
    assert list(table["inspection"]) == [1, 2]
    assert list(table["status"]) == ["altered", "not_altered"]
    assert list(table["retest_file"]) == ["retest_corked.uff", "retest_same.uff"]
    assert table["region_start_in"].iloc[0] == pytest.approx(24.0, abs=0.01)
    assert pd.isna(table["region_start_in"].iloc[1])
    assert run_cli(["export", "-o", lab / "all.csv"], capsys)[0] == 0
    assert len(pd.read_csv(lab / "all.csv")) == 2
    code, _, err = run_cli(["export", "NOPE", "-o", lab / "x.csv"], capsys)
    assert code == 2 and "unknown serial 'NOPE'" in err and not (lab / "x.csv").exists()


def test_registry_check_cli(lab, capsys):
    register(lab, capsys)
    assert run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff"], capsys)[0] == 0
    code, out, _ = run_cli(["registry", "check"], capsys)
    assert code == 0 and "intact" in out
    raw = sqlite3.connect(lab / "reg.sqlite")
    raw.execute("UPDATE inspections SET verdict_json = replace(verdict_json, "
                "'\"altered\": true', '\"altered\": false')")
    raw.commit()
    raw.close()
    code, out, _ = run_cli(["registry", "check", "--json"], capsys)
    res = json.loads(out)
    assert code == 1 and not res["ok"] and res["first_changed"] is not None
    assert any("inspection #1: stored verdict differs" in p for p in res["problems"])


def test_unwritable_report_fails_at_once_and_stores_nothing(lab, capsys, monkeypatch):
    register(lab, capsys)
    (lab / "afile").write_text("x")
    calls = []
    from updating.correlate import fitted
    monkeypatch.setattr(fitted, "fit_test", lambda *a, **k: calls.append(1))
    code, out, err = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                              "-o", lab / "afile" / "rep"], capsys)
    assert code == 2 and out == "" and "-o/--out destination not writable" in err
    assert calls == []  # refused before any work
    code, out, _ = run_cli(["history", "HX-2001", "--json"], capsys)
    assert json.loads(out)["inspections"] == []


def test_verdict_stored_and_printed_before_the_report_fails(lab, capsys, monkeypatch):
    register(lab, capsys)
    import batlab.report as report

    def broken(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(report, "figures_png", broken)
    code, out, err = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                              "-o", lab / "rep", "--json"], capsys)
    assert code == 2 and "disk full" in err and "the verdict is stored (inspection #1)" in err
    assert "batlab report HX-2001 --inspection 1" in err
    assert json.loads(out)["altered"] is True  # printed
    code, out, _ = run_cli(["history", "HX-2001", "--json"], capsys)
    (insp,) = json.loads(out)["inspections"]  # stored
    assert insp["status"] == "altered" and insp["report_path"] is None


def test_damaged_and_read_only_registries(lab, capsys):
    register(lab, capsys)
    db = lab / "reg.sqlite"
    code, _, _ = run_cli(["bats"], capsys)
    assert code == 0
    with sqlite3.connect(db) as raw:  # the bats table's first page, wherever it lies
        root = raw.execute("SELECT rootpage FROM sqlite_master WHERE name = 'bats'").fetchone()[0]
    data = bytearray(db.read_bytes())
    data[(root - 1) * 4096:root * 4096] = b"\xff" * 4096  # a damaged page
    bad = lab / "bad.sqlite"
    bad.write_bytes(bytes(data))
    for args in (["bats"], ["history", "HX-2001"], ["registry", "check"]):
        code, out, err = run_cli([*args, "--db", bad], capsys)
        lines = err.strip().splitlines()
        assert code != 0 and len(lines) <= 2, err  # never a traceback
        assert "Traceback" not in err and "bad.sqlite" in err + out
    ro = lab / "ro"
    ro.mkdir()
    shutil.copyfile(db, ro / "reg.sqlite")
    os.chmod(ro / "reg.sqlite", 0o444)
    os.chmod(ro, 0o555)
    try:
        code, out, err = run_cli(["bats", "--db", ro / "reg.sqlite"], capsys)
        assert code == 0 and "HX-2001" in out, err
        assert sorted(p.name for p in ro.iterdir()) == ["reg.sqlite"]
    finally:
        os.chmod(ro, 0o755)


def test_register_speaks_lab_units(lab, capsys):
    code, out, _ = run_cli(["register", "--profile", lab / "profile.csv", "--meta",
                            lab / "meta.json", "--baseline", lab / "baseline.uff"], capsys)
    assert code == 0 and " psi, weight density " in out and "lbf/in^3" in out
    assert "GPa" not in out and "kg/m^3" not in out
