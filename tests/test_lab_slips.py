"""The lab's slips caught at the door (#27): implausible bats, re-inspected files, the demo."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from batlab.cli import main
from batlab.pipeline.files import read_bat_files
from batlab.registry import open_registry
from updating.model import plausible
from updating.simulate.alterations import KINDS
from updating.simulate.field_fleet import draw_case, write_case
from updating.simulate.rulebook import RULEBOOK_KINDS

SAMPLE = Path("data_samples/smooth_bat").resolve()


def _bat_folder(tmp_path: Path, **meta_changes) -> Path:
    """Copy the smooth sample bat into ``tmp_path/bat`` with meta.json's keys changed."""
    folder = tmp_path / "bat"
    folder.mkdir(exist_ok=True)
    shutil.copyfile(SAMPLE / "profile.csv", folder / "profile.csv")
    meta = json.loads((SAMPLE / "meta.json").read_text())
    meta.update(meta_changes)
    (folder / "meta.json").write_text(json.dumps(meta))
    return folder


@pytest.mark.parametrize("folder",
                         sorted(p.parent for p in Path("data_samples").glob("*/meta.json")))
def test_sample_bats_are_plausible(folder):
    read_bat_files(folder / "profile.csv", folder / "meta.json")


def test_fleet_bats_are_plausible(tmp_path):
    for kind in ("none", *KINDS, *RULEBOOK_KINDS):
        for seed in range(3):
            case = draw_case(np.random.default_rng(seed), kind)
            assert plausible.check_profile(case.profile.x_m, case.profile.diameter_m, "p") is None
            assert plausible.check_meta(case.meta, "m") is None, (kind, seed)
    paths = write_case(case, tmp_path / "case", seed=0)
    read_bat_files(paths["profile"], paths["meta"])


@pytest.mark.parametrize(("key", "factor", "cause"), [
    ("weight_lb", 453.59237, "grams"), ("weight_lb", 16.0, "ounces"),
    ("nominal_E_psi", 6.894757e-3, "GPa"), ("nominal_E_psi", 6.894757, "MPa"),
    ("nominal_weight_density_lbf_in3", 27679.9, "kg/m^3"),
    ("nominal_weight_density_lbf_in3", 1 / 0.0361, "a specific gravity"),
])
def test_a_unit_slip_in_meta_is_named_and_nothing_stored(tmp_path, capsys, key, factor, cause):
    true_value = json.loads((SAMPLE / "meta.json").read_text())[key]
    folder = _bat_folder(tmp_path, **{key: true_value * factor})
    db = tmp_path / "lab.sqlite"
    code = main(["register", "--profile", str(folder / "profile.csv"), "--meta",
                 str(folder / "meta.json"), "--baseline", str(SAMPLE / "baseline.uff"),
                 "--db", str(db)])
    err = capsys.readouterr().err
    assert code == 2
    assert f"meta.json: {key}" in err and f"looks like {cause}" in err
    recovered = float(err.split(f"looks like {cause}: ")[1].split()[0])
    assert recovered == pytest.approx(true_value, rel=1e-3)
    if db.exists():
        with open_registry(db) as conn:
            assert conn.exec_driver_sql("SELECT COUNT(*) FROM bats").fetchone()[0] == 0


def test_a_species_value_far_from_the_handbook_is_refused(tmp_path):
    folder = _bat_folder(tmp_path, nominal_E_psi=5.0e6)  # white ash: 1.74e6 psi
    with pytest.raises(ValueError, match=r"meta.json: nominal_E_psi 5e\+06 is outside"):
        read_bat_files(folder / "profile.csv", folder / "meta.json")
    e_unknown, _ = plausible.handbook_range("hickory")
    assert e_unknown == pytest.approx((1.60e6 / 2, 2.02e6 * 2))
    assert plausible.check_meta({"species": "hickory", "nominal_E_psi": 3.5e6,
                                 "nominal_weight_density_lbf_in3": 0.02}, "m") is None


@pytest.mark.parametrize(("scale", "cause"), [(25.4, "millimetres"), (2.54, "centimetres")])
def test_a_profile_in_other_units_is_named(tmp_path, scale, cause):
    folder = _bat_folder(tmp_path)
    rows = np.loadtxt(SAMPLE / "profile.csv", delimiter=",", skiprows=1)
    np.savetxt(folder / "profile.csv", rows * scale, delimiter=",", header="x_in,diameter_in",
               comments="")
    length_in = scale * (rows[-1, 0] - rows[0, 0])
    with pytest.raises(ValueError, match=rf"profile.csv: the bat is {length_in:.4g} in long: "
                                         rf"{cause}\?"):
        read_bat_files(folder / "profile.csv", folder / "meta.json")


def test_a_point_before_the_knob_or_a_thin_handle_is_refused(tmp_path):
    folder = _bat_folder(tmp_path, points_in=[-3.0, 5.0])
    with pytest.raises(ValueError, match="meta.json: points_in has -3 in, before the knob"):
        read_bat_files(folder / "profile.csv", folder / "meta.json")
    x_m = np.array([0.0, 0.85])
    assert "diameter 0.3 in" in plausible.check_profile(x_m, np.array([0.3, 2.5]) * 0.0254, "p")
    assert plausible.check_profile(x_m, np.array([0.9, 2.5]) * 0.0254, "p") is None


def test_demo_without_out_leaves_nothing_behind(tmp_path, monkeypatch, capsys):
    import tempfile

    from tests.inspect_standins import use_standins

    use_standins(monkeypatch)  # the numerics are checked in test_cli_inspect_demo
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("DEMO-34A: ")
    assert "report: not kept" in out and str(scratch) not in out
    assert list(scratch.iterdir()) == []


def test_a_retest_file_inspected_twice_is_stored_once(tmp_path, monkeypatch, capsys):
    from batlab.registry import history
    from tests.inspect_standins import run_cli, use_standins

    use_standins(monkeypatch)
    db = tmp_path / "lab.sqlite"
    assert run_cli(["register", "--profile", SAMPLE / "profile.csv", "--meta",
                    SAMPLE / "meta.json", "--baseline", SAMPLE / "baseline.uff", "--db", db],
                   capsys)[0] == 0
    copy = tmp_path / "retest_again.uff"  # the same bytes under another name: same file
    shutil.copyfile(SAMPLE / "retest_corked.uff", copy)
    inspect = ["inspect", "--serial", "HX-2001", "--db", db, "--json"]
    code, first, err = run_cli([*inspect, SAMPLE / "retest_corked.uff"], capsys)
    assert code == 0 and "already inspected" not in err
    code, second, err = run_cli([*inspect, copy], capsys)
    assert code == 0 and "already inspected (inspection #1" in err and "--again" in err
    assert json.loads(second) == json.loads(first)
    with open_registry(db) as conn:
        assert len(history(conn, "HX-2001")) == 1
    code, third, err = run_cli([*inspect, copy, "--again"], capsys)
    assert code == 0 and "already inspected" not in err
    assert json.loads(third) == json.loads(first)
    code, _, err = run_cli([*inspect, copy, "--false-alarm", "0.05"], capsys)
    assert code == 0 and "already inspected" not in err
    with open_registry(db) as conn:
        assert len(history(conn, "HX-2001")) == 3
    assert run_cli(["registry", "check", "--db", db], capsys)[0] == 0


def _register(tmp_path, baseline, capsys, folder=SAMPLE):
    """Register ``folder``'s bat with ``baseline`` into a new registry: (code, stderr, db)."""
    db = tmp_path / "lab.sqlite"
    code = main(["register", "--profile", str(folder / "profile.csv"), "--meta",
                 str(folder / "meta.json"), "--baseline", str(baseline), "--db", str(db)])
    return code, capsys.readouterr().err, db


def test_a_heavier_bats_baseline_is_refused_with_its_weight(tmp_path, capsys):
    import time

    scale = np.random.default_rng().uniform(1.15, 1.25)  # same profile, heavier wood
    heavy = tmp_path / "heavy.uff"
    assert main(["simulate", "--profile", str(SAMPLE / "profile.csv"), "--meta",
                 str(SAMPLE / "meta.json"), "--density-scale", f"{scale:.4f}", "--seed", "3",
                 "-o", str(heavy)]) == 0
    capsys.readouterr()
    start = time.perf_counter()
    code, err, db = _register(tmp_path, heavy, capsys)
    assert code == 2 and time.perf_counter() - start < 60
    assert "heavy.uff: does not look like the baseline of bat HX-2001" in err
    assert "check: that" in err and "nothing stored" in err and len(err.splitlines()) < 10
    weight_lb = json.loads((SAMPLE / "meta.json").read_text())["weight_lb"]
    implied_lb = float(err.split("says the bat weighs about ")[1].split()[0])
    assert implied_lb == pytest.approx(scale * weight_lb, rel=0.06)
    assert not db.exists()


def test_another_bats_baseline_is_refused_and_no_registry_made(tmp_path, capsys):
    other = Path("data_samples/paper_bat")
    code, err, db = _register(tmp_path, other / "baseline.uff", capsys)
    assert code == 2 and "key 'points_in' has 33.00 in where" in err  # at the door, unfitted
    assert not db.exists()
    points = json.loads((other / "meta.json").read_text())["points_in"]
    folder = _bat_folder(tmp_path, points_in=points)  # its points listed: judged after the fit
    code, err, db = _register(tmp_path, other / "baseline.uff", capsys, folder)
    assert code == 2 and "misses its frequencies by" in err and "at its upper limit" in err
    assert not db.exists()
    folder = _bat_folder(tmp_path, weight_lb=873.6)
    code, err, db = _register(tmp_path, SAMPLE / "baseline.uff", capsys, folder)
    assert code == 2 and "looks like grams" in err and not db.exists()


def test_the_mass_line_of_a_bat_follows_its_weight():
    x_m, d_m = np.array([0.0, 0.5, 0.85]), np.array([0.03, 0.03, 0.065])
    a = [plausible.driving_point_mass_line(x_m, d_m, w, 0.8) for w in (0.8, 1.0)]
    assert a[0] / a[1] == pytest.approx(1.25)  # a(x_d) = 1/M + (x_d - x_c)^2 / I, both ~ 1/M
    lighter = plausible.driving_point_mass_line(x_m, d_m, 0.8, 0.8, sensor_kg=0.01)
    assert lighter < a[0]
    assert plausible.check_mass_line(a[0], x_m, d_m, 0.8, 0.8) is None
    assert "about 2.2 lb, not meta.json's weight_lb 1.764" in plausible.check_mass_line(
        a[1], x_m, d_m, 0.8, 0.8)  # a 1 kg bat's mass line


def test_a_long_step_is_never_silent(capsys):
    import re
    import time

    from batlab.cli_support import Progress, stop_all

    progress = Progress("inspect", every_s=0.05)
    progress("calibrating the reference model ...")
    time.sleep(0.3)
    stop_all()
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("batlab inspect [") and lines[0].endswith("reference model ...")
    still = [line for line in lines[1:] if "still calibrating the reference model (" in line]
    assert len(still) >= 2 and all(re.search(r"\[\s*\d+\.\d s\]", line) for line in still)
    time.sleep(0.15)
    assert capsys.readouterr().err == ""  # stopped with its command


def test_simulate_says_its_step_with_the_time(tmp_path, capsys):
    assert main(["simulate", "-o", str(tmp_path / "t.uff"), "--df", "4", "--seed", "1"]) == 0
    err = capsys.readouterr().err
    assert "batlab simulate [" in err and "s]: simulating 16 impact points, 801 lines" in err


def test_force_registers_an_odd_baseline_and_every_report_says_so(tmp_path, capsys):
    """A heavier bat's baseline, refused without --force, is registered with it; the record
    keeps why it looked odd and the inspection's report shows it on its first screen."""
    scale = np.random.default_rng().uniform(1.15, 1.25)
    heavy = tmp_path / "heavy.uff"
    assert main(["simulate", "--profile", str(SAMPLE / "profile.csv"), "--meta",
                 str(SAMPLE / "meta.json"), "--density-scale", f"{scale:.4f}", "--seed", "4",
                 "-o", str(heavy)]) == 0
    db = tmp_path / "lab.sqlite"
    args = ["register", "--profile", str(SAMPLE / "profile.csv"), "--meta",
            str(SAMPLE / "meta.json"), "--baseline", str(heavy), "--db", str(db)]
    capsys.readouterr()
    assert main(args) == 2 and not db.exists()
    capsys.readouterr()
    assert main([*args, "--force"]) == 0
    assert "registered with --force although" in capsys.readouterr().err
    from batlab.registry import get_bat

    with open_registry(db) as conn:
        why = get_bat(conn, "HX-2001").meta["registered_with_force"]
    assert "says the bat weighs about" in why
    report = tmp_path / "report"
    again = tmp_path / "heavy-again.uff"  # a second test of the same bat (not its baseline)
    assert main(["simulate", "--profile", str(SAMPLE / "profile.csv"), "--meta",
                 str(SAMPLE / "meta.json"), "--density-scale", f"{scale:.4f}", "--seed", "5",
                 "-o", str(again)]) == 0
    assert main(["inspect", "--serial", "HX-2001", str(again), "--db", str(db),
                 "-o", str(report)]) == 0
    page = (report / "index.html").read_text()
    assert page.index("registered with --force") < page.index("The evidence")
    assert "Registered with --force" in page
