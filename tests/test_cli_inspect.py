"""`batlab register / bats / history / inspect`: the contract JSON, both inspect forms, the
registry round trip, and one-line errors with exit 2 for unusable input."""

from __future__ import annotations

import json
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from batlab import pipeline
from ema.io.frf_data import FrfTest
from ema.io.frf_io import read_test, write_test
from tests.inspect_standins import SAMPLE, run_cli, stand_in_lab, unchanged_retest
from updating.inspect.verdict import Verdict
from updating.model.units import IN_TO_M

CONTRACT_KEYS = {"serial", "status", "altered", "reasons", "region_in", "core_diameter_in",
                 "fill_density_ratio", "elements"}


@pytest.fixture
def lab(tmp_path, monkeypatch):
    return stand_in_lab(tmp_path, monkeypatch)


def stateless(lab, retest="retest_corked.uff", extra=()):
    return ["inspect", "--profile", lab / "profile.csv", "--meta", lab / "meta.json",
            "--baseline", lab / "baseline.uff", "--retest", lab / retest, *extra]


def check_contract(out: dict, serial: str) -> None:
    assert CONTRACT_KEYS <= set(out)
    assert out["serial"] == serial and out["altered"] in (True, False, None)
    assert out["status"] == {True: "altered", False: "not_altered",
                             None: "inconclusive"}[out["altered"]]
    assert all(isinstance(r, str) and "\n" not in r for r in out["reasons"])
    if out["altered"]:
        a, b = out["region_in"]
        assert 0 <= a < b
        assert out["core_diameter_in"] > 0 and out["fill_density_ratio"] >= 0
    else:
        assert out["region_in"] is None and out["core_diameter_in"] is None
        assert out["fill_density_ratio"] is None
    assert out["elements"]
    for e in out["elements"]:
        assert set(e) == {"x0_in", "x1_in", "alpha", "beta"}
        assert e["x0_in"] < e["x1_in"]
    x0 = [e["x0_in"] for e in out["elements"]]
    assert x0 == sorted(x0)


def test_contract_dict_units_and_nulls():
    x0 = np.array([0.0, 0.5, 0.8]) * 1.0
    v = Verdict(True, 0.99, 0.01, 5.0, (0.6096, 0.8382), 0.0254, 0.3, {}, x0,
                np.array([0.5, 0.8, 0.86]), np.array([0.0, -0.1, -0.05]),
                np.array([0.0, -0.02, 0.01]), {})
    out = pipeline.contract_dict("S", v)
    assert out["region_in"] == [24.0, 33.0]
    assert out["core_diameter_in"] == pytest.approx(1.0)
    assert out["fill_density_ratio"] == 0.3
    assert out["elements"][1] == {"x0_in": pytest.approx(0.5 / IN_TO_M, abs=1e-4),
                                  "x1_in": pytest.approx(0.8 / IN_TO_M, abs=1e-4),
                                  "alpha": -0.1, "beta": -0.02}
    clean = Verdict(False, 0.2, 0.01, 0.1, (0.6, 0.8), 0.02, 0.3, {}, x0, x0 + 0.1,
                    np.zeros(3), np.zeros(3), {})
    out = pipeline.contract_dict("S", clean)
    assert out["altered"] is False
    assert out["region_in"] is None and out["core_diameter_in"] is None
    assert out["fill_density_ratio"] is None
    json.dumps(out)  # plain JSON types only
    assert out["status"] == "not_altered" and out["chance"]["source"] == "nominal"
    assert out["reasons"] == [  # no reason held the chance: it is one, said unmeasured
        "chance an unaltered bat differs this much: unmeasured, no calibration was looked up; "
        "the F distribution's nominal 80 % is not a measured rate"]

    unsure = Verdict(None, float("nan"), 0.01, float("nan"), None, None, None, {}, x0, x0 + 0.1,
                     np.zeros(3), np.zeros(3), {}, reasons=("units: re-export",))
    out = pipeline.contract_dict("S", unsure)
    assert out["status"] == "inconclusive" and out["altered"] is None
    assert out["reasons"] == ["units: re-export"] and out["confidence"] is None
    assert out["region_in"] is None and out["fill_density_ratio"] is None
    json.dumps(out, allow_nan=False)


def _recording(monkeypatch):
    """Patch the inspector to record the conditions it is given (stand-in verdict)."""
    from tests.inspect_standins import fake_inspect

    seen = []

    def rec(profile, reference, baseline, retest, false_alarm, conditions=None,
            registered=None, with_map=True, retest_profile=None, clean_F=None):
        seen.append((conditions, registered))
        return fake_inspect(profile, reference, baseline, retest, false_alarm,
                            retest_profile=retest_profile)

    monkeypatch.setattr(pipeline.inspection, "inspect", rec)
    return seen


def test_retest_meta_reaches_the_inspection_in_both_forms(lab, capsys, monkeypatch):
    seen = _recording(monkeypatch)
    (lab / "retest.json").write_text(json.dumps(
        {"weight_lb": 2.0, "accelerometer_mass_g": 4.1, "temperature_c": 24.0,
         "tested_on": "2026-05-02", "operator": "ignored"}))
    code, out, err = run_cli(stateless(lab, extra=["--json", "--retest-meta",
                                                   lab / "retest.json"]), capsys)
    assert code == 0, err
    check_contract(json.loads(out), "HX-2001")
    cond, registered = seen[-1]
    assert cond.weight_kg == pytest.approx(2.0 * 0.45359237)
    assert cond.sensor_mass_kg == pytest.approx(4.1e-3) and cond.temperature_c == 24.0
    assert cond.tested_on == "2026-05-02"
    meta = json.loads((lab / "meta.json").read_text())
    assert registered.weight_kg == pytest.approx(meta["weight_lb"] * 0.45359237)

    assert run_cli(["register", "--profile", lab / "profile.csv", "--meta", lab / "meta.json",
                    "--baseline", lab / "baseline.uff"], capsys)[0] == 0
    (lab / "retest.json").write_text(json.dumps({"temperature_c": 18.5}))  # keys optional
    code, out, err = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                              "--retest-meta", lab / "retest.json", "--json"], capsys)
    assert code == 0, err
    cond, registered = seen[-1]
    assert cond.temperature_c == 18.5 and cond.weight_kg is None
    assert registered.weight_kg == pytest.approx(meta["weight_lb"] * 0.45359237)
    code, out, _ = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                            "--json"], capsys)
    assert code == 0 and seen[-1][0] is None  # without retest.json


@pytest.mark.parametrize("content,expect", [
    ('{"weight_lb": 2.2', "not valid JSON"),
    ('[1, 2]', "expected a JSON object"),
    ('{"weight_lb": "heavy"}', "key 'weight_lb' must be a number"),
    ('{"accelerometer_mass_g": -1}', "key 'accelerometer_mass_g' = -1 is outside"),
    ('{"temperature_c": 400}', "key 'temperature_c' = 400 is outside"),
    ('{"tested_on": "yesterday"}', "key 'tested_on' must be a date"),
])
def test_bad_retest_meta_is_refused_in_one_line(lab, capsys, content, expect):
    (lab / "retest.json").write_text(content)
    for form in ("stateless", "registry"):
        if form == "stateless":
            args = stateless(lab, extra=["--json", "--retest-meta", lab / "retest.json"])
        else:
            assert run_cli(["register", "--profile", lab / "profile.csv", "--meta",
                            lab / "meta.json", "--baseline", lab / "baseline.uff",
                            "--replace"], capsys)[0] == 0
            args = ["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                    "--retest-meta", lab / "retest.json", "--json"]
        code, out, err = run_cli(args, capsys)
        assert code == 2 and out == ""
        last = err.strip().splitlines()[-1]
        assert "retest.json" in last and expect in last
        assert "fitting modes" not in err  # refused before any work
    code, out, _ = run_cli(["history", "HX-2001", "--json"], capsys)
    assert json.loads(out)["inspections"] == []  # nothing stored


def test_stateless_inspect_json(lab, capsys):
    code, out, err = run_cli(stateless(lab, extra=["--json"]), capsys)
    assert code == 0
    res = json.loads(out)  # stdout holds the JSON object and nothing else
    check_contract(res, "HX-2001")
    assert res["altered"] is True
    assert "fitting modes" in err and "inspecting" in err  # progress on stderr

    unchanged_retest(lab / "baseline.uff", lab / "second.uff")
    code, out, _ = run_cli(stateless(lab, retest="second.uff", extra=["--json"]), capsys)
    assert code == 0
    res = json.loads(out)
    check_contract(res, "HX-2001")
    assert res["altered"] is False  # a second test of the unaltered bat


def test_readable_output(lab, capsys):
    code, out, _ = run_cli(stateless(lab), capsys)
    assert code == 0
    assert out.startswith("HX-2001: ALTERED")
    assert "altered region 24.0 to 33.0 in" in out


def test_registry_form_gives_the_same_verdict(lab, capsys):
    code, out, err = run_cli(["register", "--profile", lab / "profile.csv", "--meta",
                              lab / "meta.json", "--baseline", lab / "baseline.uff", "--json"],
                             capsys)
    assert code == 0, err
    reg_out = json.loads(out)
    assert reg_out["serial"] == "HX-2001" and len(reg_out["modes_hz"]) >= 3
    (lab / "baseline.uff").unlink()  # the registry holds its own copy

    code, out, _ = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                            "--json"], capsys)
    assert code == 0
    via_registry = json.loads(out)
    shutil.copyfile(SAMPLE / "baseline.uff", lab / "baseline.uff")
    code, out, _ = run_cli(stateless(lab, extra=["--json"]), capsys)
    assert json.loads(out) == via_registry

    code, out, _ = run_cli(["history", "HX-2001", "--json"], capsys)
    hist = json.loads(out)
    assert len(hist["inspections"]) == 1
    insp = hist["inspections"][0]
    assert insp["altered"] is True and insp["retest_name"] == "retest_corked.uff"
    assert {k: insp["verdict"][k] for k in via_registry} == via_registry
    code, out, _ = run_cli(["bats", "--json"], capsys)
    (bat,) = json.loads(out)
    assert bat["serial"] == "HX-2001" and bat["n_inspections"] == 1 and bat["last_altered"]
    code, out, _ = run_cli(["bats"], capsys)
    assert "HX-2001" in out and "ALTERED" in out
    code, out, _ = run_cli(["history", "HX-2001"], capsys)
    assert "retest_corked.uff" in out


def test_reregister_needs_replace(lab, capsys):
    args = ["register", "--serial", "HX-2001", "--profile", lab / "profile.csv", "--meta",
            lab / "meta.json", "--baseline", lab / "baseline.uff"]
    assert run_cli(args, capsys)[0] == 0
    code, out, err = run_cli(args, capsys)
    assert code == 2 and out == ""
    assert "already registered" in err and len(err.strip().splitlines()) == 1  # before fitting
    code, out, _ = run_cli([*args, "--replace"], capsys)
    assert code == 0 and "registered HX-2001" in out


def _truncate(src: Path, dst: Path) -> None:
    data = src.read_bytes()
    dst.write_bytes(data[: len(data) // 2])


def _fewer_points(src: Path, dst: Path) -> None:
    t = read_test(src)
    keep = t.reference_nodes != t.reference_nodes[3]
    write_test(dst, FrfTest(t.freq_hz, t.frf[:, :, keep], t.response_nodes,
                            t.reference_nodes[keep], t.node_x_m, t.quantity))


def _moved_points(src: Path, dst: Path) -> None:
    t = read_test(src)
    moved = {n: x + 0.02 for n, x in t.node_x_m.items()}
    write_test(dst, FrfTest(t.freq_hz, t.frf, t.response_nodes, t.reference_nodes, moved,
                            t.quantity))


@pytest.mark.parametrize("case", ["missing", "truncated", "decreasing", "fewer", "moved",
                                  "serial_mismatch", "bad_meta"])
def test_stateless_bad_input(lab, capsys, case):
    args = stateless(lab, extra=["--json"])
    expect = {
        "missing": "no such file", "truncated": "retest_corked.uff",
        "decreasing": "x decreases", "fewer": "16 test points, the baseline has 17",
        "moved": "do not match", "serial_mismatch": "differs", "bad_meta": "meta.json",
    }[case]
    if case == "missing":
        (lab / "retest_corked.uff").unlink()
    elif case == "truncated":
        _truncate(SAMPLE / "retest_corked.uff", lab / "retest_corked.uff")
    elif case == "decreasing":
        lines = (lab / "profile.csv").read_text().splitlines()
        lines[5], lines[6] = lines[6], lines[5]
        (lab / "profile.csv").write_text("\n".join(lines) + "\n")
    elif case == "fewer":
        _fewer_points(SAMPLE / "retest_corked.uff", lab / "retest_corked.uff")
    elif case == "moved":
        _moved_points(SAMPLE / "retest_corked.uff", lab / "retest_corked.uff")
    elif case == "serial_mismatch":
        args = ["register", "--serial", "OTHER", "--profile", lab / "profile.csv", "--meta",
                lab / "meta.json", "--baseline", lab / "baseline.uff"]
    elif case == "bad_meta":
        (lab / "meta.json").write_text('{"serial": "X"')
    code, out, err = run_cli(args, capsys)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert lines[-1].startswith("batlab ") and expect in lines[-1]
    assert all("error" not in line for line in lines[:-1])  # a single error line


def test_registry_bad_input(lab, capsys):
    assert run_cli(["register", "--profile", lab / "profile.csv", "--meta", lab / "meta.json",
                    "--baseline", lab / "baseline.uff"], capsys)[0] == 0
    code, _, err = run_cli(["inspect", "--serial", "NOPE", lab / "retest_corked.uff"], capsys)
    assert code == 2 and "unknown serial 'NOPE'" in err
    code, _, err = run_cli(["history", "NOPE"], capsys)
    assert code == 2 and "unknown serial" in err
    _fewer_points(SAMPLE / "retest_corked.uff", lab / "fewer.uff")
    code, _, err = run_cli(["inspect", "--serial", "HX-2001", lab / "fewer.uff"], capsys)
    assert code == 2 and "16 test points" in err
    code, _, err = run_cli(["inspect", "--serial", "HX-2001"], capsys)
    assert code == 2 and "no re-test file" in err
    code, _, err = run_cli(["inspect", "--serial", "HX-2001", "--profile", "p.csv", "r.uff"],
                           capsys)
    assert code == 2 and "drop --profile" in err
    code, _, err = run_cli(["inspect", "--profile", lab / "profile.csv", "--retest", "r.uff"],
                           capsys)
    assert code == 2 and "--baseline" in err

    raw = sqlite3.connect(lab / "reg.sqlite")
    raw.execute("UPDATE files SET content = substr(content, 1, length(content) - 1)")
    raw.commit()
    raw.close()
    code, out, err = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff"],
                             capsys)
    assert code == 2 and out == "" and "checksum" in err
    assert len(err.strip().splitlines()) == 1
    code, out, _ = run_cli(["history", "HX-2001", "--json"], capsys)
    assert json.loads(out)["inspections"] == []  # nothing stored for the refused inspection


def test_cli_process_missing_file_exit_code(tmp_path):
    """The real process: exit 2, one line on stderr, nothing on stdout."""
    res = subprocess.run(
        [sys.executable, "-m", "batlab", "inspect", "--profile", str(SAMPLE / "profile.csv"),
         "--meta", str(SAMPLE / "meta.json"), "--baseline", str(tmp_path / "nope.uff"),
         "--retest", str(SAMPLE / "retest_corked.uff"), "--json"],
        capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and res.stdout == ""
    assert res.stderr.strip() == (f"batlab inspect: error: {tmp_path / 'nope.uff'}: no such file "
                                  "(--baseline: the baseline test)")


def test_report_option_both_forms(lab, capsys):
    code, out, err = run_cli(stateless(lab, extra=["--json", "-o", lab / "rep1"]), capsys)
    assert code == 0
    check_contract(json.loads(out), "HX-2001")  # stdout still holds only the JSON
    assert (lab / "rep1" / "index.html").is_file() and "report:" in err
    assert run_cli(["register", "--profile", lab / "profile.csv", "--meta", lab / "meta.json",
                    "--baseline", lab / "baseline.uff"], capsys)[0] == 0
    code, out, _ = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                            "-o", lab / "rep2"], capsys)
    assert code == 0 and out.startswith("HX-2001: ALTERED")
    code, out, _ = run_cli(["history", "HX-2001", "--json"], capsys)
    (insp,) = json.loads(out)["inspections"]
    assert insp["report_path"] == str(lab / "rep2" / "index.html")
    assert "retest_corked.uff" in (lab / "rep2" / "index.html").read_text()


def test_reading_commands_need_an_existing_registry(tmp_path, capsys):
    db = tmp_path / "none.sqlite"
    for args in (["bats"], ["history", "S"],
                 ["inspect", "--serial", "S", SAMPLE / "retest_corked.uff"]):
        code, out, err = run_cli([*args, "--db", db], capsys)
        assert code == 2 and out == "" and "no registry there" in err
    assert not db.exists()
