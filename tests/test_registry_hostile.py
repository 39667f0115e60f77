"""The registry under hostile hands and small faults (issue 48): the baseline given as its own
re-test, the same re-test inspected twice at once, text that attacks its reader (a terminal,
a spreadsheet, a page), a signing key open to others, a broken pipe, a report's stale
temporary file, the report hint's --db, and meta.json's model key said and done alike.
The numerics are the test-only stand-ins."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from tests.inspect_standins import run_cli, stand_in_lab, unchanged_retest

HOSTILE = "white\x1b[31m ash\x00\u202e\u200f"  # an ANSI colour, a NUL, RTL override and mark


@pytest.fixture
def lab(tmp_path, monkeypatch):
    return stand_in_lab(tmp_path, monkeypatch)


def register(lab: Path, capsys, **meta) -> tuple[int, str, str]:
    if meta:
        m = json.loads((lab / "meta.json").read_text())
        m.update(meta)
        (lab / "meta.json").write_text(json.dumps(m))
    return run_cli(["register", "--profile", lab / "profile.csv", "--meta", lab / "meta.json",
                    "--baseline", lab / "baseline.uff"], capsys)


def test_the_baseline_as_its_own_retest_is_refused_in_both_forms(lab, capsys):
    from ema.io.frf_io import read_test, write_test

    write_test(lab / "baseline-again.csv", read_test(lab / "baseline.uff"))  # same FRFs
    stateless = ["inspect", "--profile", lab / "profile.csv", "--meta", lab / "meta.json",
                 "--baseline", lab / "baseline.uff", "--retest"]
    assert register(lab, capsys)[0] == 0
    for args in (stateless, ["inspect", "--serial", "HX-2001"]):
        for twin, said in (("baseline.uff", "the same bytes"),
                           ("baseline-again.csv", "its FRFs equal")):
            code, out, err = run_cli([*args, lab / twin, "--json"], capsys)
            assert code == 2 and out == "", err
            (line,) = err.strip().splitlines()
            assert said in line and str(lab / twin) in line and "baseline.uff" in line
            assert "fitting" not in err
    code, out, _ = run_cli(["history", "HX-2001", "--json"], capsys)
    assert json.loads(out)["inspections"] == []  # nothing stored
    unchanged_retest(lab / "baseline.uff", lab / "second.uff")  # a real second test passes
    for args in (stateless, ["inspect", "--serial", "HX-2001"]):
        code, out, err = run_cli([*args, lab / "second.uff", "--json"], capsys)
        assert code == 0 and json.loads(out)["status"] == "not_altered", err


def test_the_same_retest_inspected_twice_at_once_is_stored_once(lab, capsys, monkeypatch):
    """A second `inspect` of the same re-test runs to its end while the first is between its
    "already inspected?" question and its store (the modal fit's minutes, in the lab)."""
    import batlab.pipeline.inspection as inspection
    from batlab.cli import main

    assert register(lab, capsys)[0] == 0
    retest = lab / "retest_corked.uff"
    judge_alone, inner = inspection.inspect, []

    def meanwhile(*args, **kwargs):
        if not inner:  # the first inspection: the second one runs now, from start to end
            inner.append(None)
            inner[0] = main(["inspect", "--serial", "HX-2001", str(retest), "--json"])
        return judge_alone(*args, **kwargs)

    monkeypatch.setattr(inspection, "inspect", meanwhile)
    code, out, err = run_cli(["inspect", "--serial", "HX-2001", retest, "--json"], capsys)
    assert inner == [0] and code == 0, err
    assert [json.loads(line)["status"] for line in out.splitlines()] == ["altered"] * 2
    assert "already inspected (inspection #1" in err
    code, out, _ = run_cli(["history", "HX-2001", "--json"], capsys)
    assert [i["id"] for i in json.loads(out)["inspections"]] == [1]  # stored once
    code, out, _ = run_cli(["registry", "check"], capsys)
    assert code == 0, out


def _edit(db: Path, sql: str) -> None:
    import sqlite3

    raw = sqlite3.connect(db)
    raw.execute(sql)
    raw.commit()
    raw.close()


def _problems(capsys, db: Path) -> list[str]:
    code, out, _ = run_cli(["registry", "check", "--db", db, "--json"], capsys)
    res = json.loads(out)
    assert (code == 0) == res["ok"]
    return res["problems"]


@pytest.mark.parametrize("edit", [
    "UPDATE files SET name = 'retest_clean.uff' WHERE name = 'retest_corked.uff'",
    "UPDATE files SET size = size + 1 WHERE name = 'retest_corked.uff'",
    "UPDATE files SET size = 7 WHERE name = 'baseline.uff'",
])
def test_every_column_of_a_stored_file_is_under_custody(lab, capsys, tmp_path, edit):
    import shutil

    assert register(lab, capsys)[0] == 0
    assert run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff"], capsys)[0] == 0
    db = tmp_path / "edited.sqlite"
    shutil.copyfile(lab / "reg.sqlite", db)
    assert _problems(capsys, db) == []
    _edit(db, edit)
    problems = _problems(capsys, db)
    assert any("stored row (name, size) differs from custody record" in p for p in problems), \
        problems


def test_file_records_of_an_older_registry_still_verify(tmp_path, capsys, monkeypatch):
    """A registry written before file records covered name and size (the schema-4 file,
    migrated) verifies, says what its older file records cannot cover, and takes new ones."""
    import shutil

    db = tmp_path / "old.sqlite"
    shutil.copyfile(Path("tests/data/registry_schema4.sqlite"), db)
    trust = ["--trust", "tests/data/registry_schema4.trust"]
    code, out, _ = run_cli(["registry", "check", "--db", db, "--json", *trust], capsys)
    res = json.loads(out)
    assert code == 0 and res["ok"], res["problems"]
    assert any("were written before file records covered a file's name and size" in n
               for n in res["notes"])
    _edit(db, "UPDATE files SET name = 'renamed.uff'")  # still checked against its payload
    code, out, _ = run_cli(["registry", "check", "--db", db, "--json", *trust], capsys)
    assert code == 1 and any("stored row (name, size) differs" in p
                             for p in json.loads(out)["problems"])


def test_report_refuses_a_verdict_changed_after_signing(lab, capsys):
    assert register(lab, capsys)[0] == 0
    assert run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff"], capsys)[0] == 0
    assert run_cli(["report", "HX-2001", "-o", lab / "before"], capsys)[0] == 0
    _edit(lab / "reg.sqlite", "UPDATE inspections SET status = 'not_altered', verdict_json = "
          "replace(verdict_json, '\"altered\": true', '\"altered\": false')")
    code, out, err = run_cli(["report", "HX-2001", "-o", lab / "after"], capsys)
    assert code == 2 and out == "" and not (lab / "after" / "index.html").exists(), err
    (line,) = err.strip().splitlines()[-1:]
    assert "inspection #1 of 'HX-2001' differs from its signed verdict record #4" in line
    assert 'status: "altered" in the record, "not_altered" in the row' in line
    assert "verdict.altered: true in the record, false in the row" in line


def test_terminal_output_escapes_control_characters(lab, capsys):
    code, _, err = register(lab, capsys, species=HOSTILE, note="\x1b]0;pwned\x07")
    assert code == 0, err
    assert run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff"], capsys)[0] == 0
    for args in (["bats"], ["history", "HX-2001"]):
        code, out, err = run_cli(args, capsys)
        assert code == 0, err
        for bad in ("\x1b", "\x00", "\u202e", "\u200f", "\x07"):
            assert bad not in out + err, (args, out)
    code, out, _ = run_cli(["bats"], capsys)
    assert "white\\x1b[31m ash\\x00\\u202e\\u200f" in out  # escaped, still readable
    code, out, _ = run_cli(["bats", "--json"], capsys)
    assert json.loads(out)[0]["species"] == HOSTILE  # JSON keeps the value, escaped by JSON


def test_export_neutralises_spreadsheet_formulas(lab, capsys):
    code, _, err = register(lab, capsys, species="=cmd|' /C calc'!A0")
    assert code == 0, err
    (lab / "-2+3.uff").write_bytes((lab / "retest_corked.uff").read_bytes())
    assert run_cli(["inspect", "--serial", "HX-2001", lab / "-2+3.uff"], capsys)[0] == 0
    code, _, err = run_cli(["export", "-o", lab / "h.csv"], capsys)
    assert code == 0, err
    text = (lab / "h.csv").read_text()
    assert "\n=" not in text and ",=" not in text and ",-2+3" not in text
    row = pd.read_csv(lab / "h.csv").iloc[0]
    assert row["species"] == "'=cmd|' /C calc'!A0" and row["retest_file"] == "'-2+3.uff"
    assert row["inspection"] == 1 and row["status"] == "altered"  # numbers stay numbers


def test_no_nul_reaches_a_report_page(lab, capsys):
    code, _, err = register(lab, capsys, species="ash\x00\x00", model="Pro\x00271")
    assert code == 0, err
    code, _, err = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                            "-o", lab / "rep"], capsys)
    assert code == 0, err
    page = (lab / "rep" / "index.html").read_text()
    assert "\x00" not in page and "ash\ufffd\ufffd" in page
    code, out, _ = run_cli(["registry", "check", "--report", lab / "rep" / "index.html"],
                           capsys)
    assert code == 0, out  # the page as written is the page sealed


def test_a_report_run_removes_a_killed_writers_temporary_page(lab, capsys):
    assert register(lab, capsys)[0] == 0
    rep = lab / "rep"
    rep.mkdir()
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()
    stale = rep / f".index.html.{dead}.k1ll3d.tmp"  # a writer killed before its rename
    stale.write_text("<html>half")
    live = rep / f".index.html.{os.getpid()}.wr1t1n.tmp"  # a writer still running: kept
    live.write_text("<html>")
    code, _, err = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                            "-o", rep], capsys)
    assert code == 0, err
    assert not stale.exists() and live.exists() and (rep / "index.html").is_file()


def test_the_report_hint_keeps_the_db(lab, capsys, monkeypatch):
    db = lab / "other place.sqlite"
    code, _, err = run_cli(["register", "--profile", lab / "profile.csv", "--meta",
                            lab / "meta.json", "--baseline", lab / "baseline.uff", "--db", db],
                           capsys)
    assert code == 0, err
    import batlab.report as report

    def broken(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(report, "figures_png", broken)
    code, _, err = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                            "-o", lab / "rep", "--db", db], capsys)
    assert code == 2
    assert f"batlab report HX-2001 --inspection 1 --db '{db}'" in err


def test_the_model_key_is_not_called_ignored(lab, capsys):
    code, _, err = register(lab, capsys, model="Pro 271", colour="red")
    assert code == 0, err
    assert "'colour' not used (ignored)" in err and "'model'" not in err
    code, out, err = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                              "--json"], capsys)
    assert code == 0 and json.loads(out)["chance"]["model"] == "Pro 271"


def test_a_signing_key_open_to_others_is_refused(lab, capsys, monkeypatch, tmp_path):
    # stat's mode bits, not an access that root would pass: this fails as root too
    key = tmp_path / "lab-key.pem"
    monkeypatch.setenv("BATLAB_KEY", str(key))
    code, out, _ = run_cli(["registry", "key"], capsys)
    assert code == 0 and (key.stat().st_mode & 0o777) == 0o600
    os.chmod(key, 0o644)
    for args in (["registry", "key"], ["register", "--profile", lab / "profile.csv", "--meta",
                                       lab / "meta.json", "--baseline",
                                       lab / "baseline.uff"]):
        code, out, err = run_cli(args, capsys)
        assert code == 2 and out == "", err
        assert f"run `chmod 600 {key}`" in err and "mode 0644" in err
    assert not (lab / "reg.sqlite").exists() or run_cli(["bats", "--json"], capsys)[1] == "[]\n"
    os.chmod(key, 0o600)
    assert register(lab, capsys)[0] == 0


def test_registry_check_into_a_closed_pipe_keeps_its_status(lab, capsys):
    assert register(lab, capsys)[0] == 0
    read, write = os.pipe()
    os.close(read)  # the reader (`| head -1`) is gone before a line is written
    try:
        proc = subprocess.run([sys.executable, "-m", "batlab", "registry", "check"],
                              stdout=write, stderr=subprocess.PIPE, text=True,
                              env={**os.environ}, timeout=120)
    finally:
        os.close(write)
    assert proc.returncode == 0, proc.stderr  # intact: check's own status, not 2
    assert "Broken pipe" not in proc.stderr and "Traceback" not in proc.stderr
