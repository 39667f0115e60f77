"""The caliper survey joined with the vibration test's verdict (issue 38), and
``--retest-profile`` through the command line in both forms and ``fleet inspect``'s jobs.

The joining is checked on the project's simulated surveys against stand-in modal verdicts;
the command line with the stand-in numerics (``tests.inspect_standins``: the calipers'
comparison itself is real, pure numpy) and once end to end on a field bat.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import replace

import numpy as np
import pytest

from batlab.pipeline.records import contract_dict
from tests.inspect_standins import SAMPLE, judged, run_cli, stand_in_lab, unchanged_retest
from updating.inspect.caliper_verdict import join_calipers, with_calipers
from updating.inspect.calipers import compare_profiles
from updating.inspect.finding import Finding
from updating.inspect.verdict import Verdict
from updating.model.calipers import write_survey_csv
from updating.model.local_change import LocalChange
from updating.model.profile import Profile, read_profile_csv
from updating.model.units import IN_TO_M
from updating.simulate.calipers import Ovality, draw_ovality, orientations_deg, read_bat
from updating.simulate.fleet import pro_profile

RHO = 650.0


def _modal(altered=False, finding=None, reasons=("the change between the tests is what "
                                                 "moisture, temperature and the accelerometer "
                                                 "make (p = 0.4)",)):
    """A stand-in vibration verdict (drift, or what ``finding`` says)."""
    x = np.linspace(0.0, 0.84, 5)
    region = finding.region_m if finding is not None else None
    return Verdict(altered, 0.6, 0.01, 1.2, region, None, None, {"stiffness_scale": 0.01}, x[:-1],
                   x[1:], np.zeros(4), np.zeros(4), {}, reasons=tuple(reasons), finding=finding)


def _bat(seed=3):
    rng = np.random.default_rng(seed)
    truth = pro_profile(rng)
    return rng, truth, Profile(truth.x_m, truth.diameter_m + 0.003 * IN_TO_M
                               * rng.standard_normal(truth.x_m.size))


def _survey(rng, truth, changes, ovality=None):
    return read_bat(rng, truth, tuple(changes), np.unique(truth.x_m), orientations_deg(4),
                    ovality or draw_ovality(rng))


def _flat(truth, depth_in=0.05, angle=90.0, x0_in=9.0, x1_in=2.0):
    L = truth.length_m
    return LocalChange(L - x0_in * IN_TO_M, L - x1_in * IN_TO_M, flat_depth_m=depth_in * IN_TO_M,
                       flat_angle_deg=angle)


def test_a_measured_flat_makes_the_bat_altered_with_the_calipers_finding():
    rng, truth, registered = _bat()
    flat = _flat(truth)
    v = with_calipers(_modal(), registered, _survey(rng, truth, [flat]), RHO)
    assert v.altered is True and v.calipers is not None
    f = v.finding
    assert (f.kind, f.rule, f.legal, f.family) == ("material_removed", "flat-surfaced", False,
                                                   "calipers")
    assert abs(f.region_m[0] - flat.x0_m) < 1.5 * IN_TO_M and v.region_m == f.region_m
    assert abs(f.reading["flat_angle_deg"] - 90.0) < 3 * f.uncertainty["flat_angle_deg"] + 2
    assert v.reasons[0].startswith("the re-test's caliper profile measures a flat")
    assert "a measurement, not an inference" in v.reasons[0]
    assert v.reasons[-1].startswith("vibration test: the change between the tests")
    out = contract_dict("S-1", v)
    assert out["status"] == "altered" and out["core_diameter_in"] is None
    assert set(out["finding"]["reading"]) == {"diameter_lost_in", "removed_mass_g",
                                              "flat_angle_deg"}
    assert {"diameter_lost_in", "removed_mass_g", "flat_angle_deg", "region_start_in"} <= \
        set(out["finding"]["uncertainty"])
    assert out["region_in"] == out["finding"]["region_in"]


def test_measured_rings_read_grooved_and_a_core_keeps_its_finding():
    rng, truth, registered = _bat(4)
    x = np.unique(truth.x_m)
    at = [x[np.argmin(np.abs(x - (truth.length_m - a * IN_TO_M)))] for a in (6, 5, 4)]
    rings = [LocalChange(s - 0.1 * IN_TO_M, s + 0.1 * IN_TO_M, diameter_loss_m=0.08 * IN_TO_M)
             for s in at]  # each round a station
    L = truth.length_m
    result = compare_profiles(registered, _survey(rng, truth, rings), RHO)
    v = join_calipers(_modal(), result)
    assert v.altered is True and v.finding.rule == "grooved"
    assert v.finding.reading["n_grooves"] == 3
    assert v.finding.reading["diameter_lost_m"] == pytest.approx(0.08 * IN_TO_M,
                                                                 abs=0.01 * IN_TO_M)
    core = Finding("core", False, (L - 10 * IN_TO_M, L), "filled",
                   {"core_diameter_m": 0.025, "fill_density_ratio": 0.3})
    cored = join_calipers(_modal(True, core, ("a core",)), result)
    assert cored.finding == core and cored.altered is True
    assert cored.reasons[0] == "a core" and "caliper profile measures 3 rings" in cored.reasons[1]


def test_no_removal_leaves_the_vibration_verdict_and_says_what_it_cannot_see():
    rng, truth, registered = _bat(5)
    clean = _survey(rng, truth, [])
    v = with_calipers(_modal(), registered, clean, RHO)
    assert v.altered is False and v.finding is None
    assert v.reasons[0] == _modal().reasons[0]
    last = v.reasons[-1]
    assert "reads no removal beyond noise and ovality, which is not evidence of a clean " \
           "barrel" in last
    assert "not measurable by this survey (every 22.5 deg" in last and "every 0.1 in" in last
    # a loss the vibration test read (material removed, altered) stays, with the same words
    removed = Finding("material_removed", False, (0.6, 0.8), "flat-surfaced",
                      {"diameter_lost_m": 0.001, "removed_mass_kg": 0.003})
    kept = with_calipers(_modal(True, removed, ("it fits a flat",)), registered, clean, RHO)
    assert kept.altered is True and kept.finding == removed and kept.reasons[0] == \
        "it fits a flat"


def test_a_grip_cleaned_off_the_handle_and_a_caliper_zeroed_wrong_are_no_alteration():
    rng, truth, _ = _bat(6)
    x, d = truth.x_m, truth.diameter_m
    tar = np.where((x > 1 * IN_TO_M) & (x < 15 * IN_TO_M), 0.015 * IN_TO_M, 0.0)
    with_tar = Profile(x, d + tar + 0.002 * IN_TO_M * rng.standard_normal(x.size))
    v = with_calipers(_modal(), with_tar, _survey(rng, truth, []), RHO)
    assert v.altered is False
    assert any("on the handle, within 18 in of the knob" in r and "not an alteration" in r
               for r in v.reasons)
    zero = _survey(rng, truth, [])
    zero = replace(zero, diameter_m=zero.diameter_m - 0.03 * IN_TO_M)
    v = with_calipers(_modal(), Profile(x, d), zero, RHO)
    assert v.altered is False
    assert any("along most of the bat" in r and "zeroed wrong" in r for r in v.reasons)


@pytest.fixture
def lab(tmp_path, monkeypatch):
    """The sample bat's files, stand-in numerics, and a re-test caliper profile with a flat."""
    stand_in_lab(tmp_path, monkeypatch)
    truth = read_profile_csv(SAMPLE / "profile.csv")
    rng = np.random.default_rng(8)
    L = truth.length_m
    flat = LocalChange(L - 10 * IN_TO_M, L - 2 * IN_TO_M, flat_depth_m=0.05 * IN_TO_M,
                       flat_angle_deg=135.0)
    write_survey_csv(tmp_path / "retest_profile.csv",
                     read_bat(rng, truth, (flat,), np.unique(truth.x_m), orientations_deg(4),
                              Ovality(0.002 * IN_TO_M, 10.0, 5.0)))
    return tmp_path


def test_retest_profile_in_both_forms_gives_the_same_measured_flat(lab, capsys):
    # the modes do not move (a second test of the unaltered bat): the vibration test reads drift
    same = unchanged_retest(lab / "baseline.uff", lab / "second.uff")
    code, out, err = run_cli(["inspect", "--profile", lab / "profile.csv", "--meta",
                              lab / "meta.json", "--baseline", lab / "baseline.uff",
                              "--retest", same, "--retest-profile", lab / "retest_profile.csv",
                              "--json"], capsys)
    assert code == 0, err
    stateless = json.loads(out)
    assert stateless["status"] == "altered"
    assert stateless["finding"]["rule"] == "flat-surfaced"
    assert stateless["finding"]["reading"]["flat_angle_deg"] == pytest.approx(135, abs=25)
    assert run_cli(["register", "--profile", lab / "profile.csv", "--meta", lab / "meta.json",
                    "--baseline", lab / "baseline.uff"], capsys)[0] == 0
    serial = ["inspect", "--serial", "HX-2001", same, "--json"]
    code, out, err = run_cli([*serial, "--retest-profile", lab / "retest_profile.csv"], capsys)
    assert code == 0, err
    assert judged(json.loads(out)) == judged(stateless)
    code, out, err = run_cli(serial, capsys)  # without it: judged again, not the stored one
    assert code == 0 and "already inspected" not in err
    assert json.loads(out)["status"] == "not_altered"
    from batlab.pipeline.stored import survey_from_dict
    from batlab.registry import history, open_registry
    from updating.model.calipers import read_survey_csv

    with open_registry(lab / "reg.sqlite") as conn:  # kept with its inspection, to judge again
        first, second = history(conn, "HX-2001")
    kept = survey_from_dict(first.inputs["retest_profile"])
    read = read_survey_csv(lab / "retest_profile.csv")
    np.testing.assert_array_equal(kept.diameter_m, read.diameter_m)
    np.testing.assert_array_equal(kept.angle_deg, read.angle_deg)
    assert "retest_profile" not in second.inputs


def test_a_retest_profile_slip_is_refused_before_any_fit_and_nothing_stored(lab, capsys):
    rows = np.loadtxt(lab / "retest_profile.csv", delimiter=",", skiprows=1)
    rows[:, 1] *= 25.4
    bad = lab / "mm.csv"
    np.savetxt(bad, rows, delimiter=",", header="x_in,diameter_in,angle_deg", comments="")
    assert run_cli(["register", "--profile", lab / "profile.csv", "--meta", lab / "meta.json",
                    "--baseline", lab / "baseline.uff"], capsys)[0] == 0
    for args in (["--profile", lab / "profile.csv", "--meta", lab / "meta.json", "--baseline",
                  lab / "baseline.uff", "--retest"], ["--serial", "HX-2001"]):
        code, out, err = run_cli(["inspect", *args, lab / "retest_corked.uff", "--retest-profile",
                                  bad, "--json"], capsys)
        assert code == 2 and out == ""
        assert err.strip().splitlines()[-1].endswith("millimetres?")
        assert "mm.csv" in err and "fitting modes" not in err
    code, out, _ = run_cli(["history", "HX-2001", "--json"], capsys)
    assert json.loads(out)["inspections"] == []


def test_fleet_inspect_finds_serial_profile_csv_beside_its_retest(lab, capsys):
    from batlab.fleet.inspect_fleet import inspect_job, retest_jobs

    assert run_cli(["register", "--profile", lab / "profile.csv", "--meta", lab / "meta.json",
                    "--baseline", lab / "baseline.uff"], capsys)[0] == 0
    folder = lab / "retests"
    folder.mkdir()
    unchanged_retest(lab / "baseline.uff", folder / "HX-2001.uff")
    shutil.copyfile(lab / "retest_profile.csv", folder / "HX-2001.profile.csv")
    shutil.copyfile(lab / "baseline.uff", folder / "HX-2002.uff")
    jobs = retest_jobs(folder)
    assert [j.retest_profile_path for j in jobs] == [str(folder / "HX-2001.profile.csv"), None]
    result = inspect_job(str(lab / "reg.sqlite"), 0.01, jobs[0])
    assert result.verdict.altered is True and result.verdict.finding.rule == "flat-surfaced"
    assert result.survey is not None


def test_a_flattened_field_bat_end_to_end_in_both_forms(tmp_path, capsys):
    """A nuisance-rich field bat flattened 0.024 in over 8.4 in (``field_fleet`` seed 42),
    its re-test profile at four orientations: the real pipeline, files to verdict, calls it
    altered, flat-surfaced, where the flat is -- statelessly and against the registry."""
    from updating.simulate.field_fleet import draw_case, write_case

    case = draw_case(np.random.default_rng(42), "flattened")
    paths = write_case(case, tmp_path / "bat", seed=7, retest_profile=4)
    truth = case.truth["finding"]
    code, out, err = run_cli(["inspect", "--profile", paths["profile"], "--meta", paths["meta"],
                              "--baseline", paths["baseline"], "--retest", paths["retest"],
                              "--retest-meta", paths["retest_meta"], "--retest-profile",
                              paths["retest_profile"], "--json"], capsys)
    assert code == 0, err
    stateless = json.loads(out)
    assert stateless["status"] == "altered"
    f = stateless["finding"]
    assert (f["kind"], f["rule"]) == ("material_removed", "flat-surfaced")
    assert abs(f["region_in"][0] - truth["region_in"][0]) <= 1.5
    assert "caliper profile measures" in stateless["reasons"][0]
    db = tmp_path / "lab.sqlite"
    assert run_cli(["register", "--profile", paths["profile"], "--meta", paths["meta"],
                    "--baseline", paths["baseline"], "--db", db], capsys)[0] == 0
    code, out, err = run_cli(["inspect", "--serial", case.meta["serial"], paths["retest"],
                              "--retest-meta", paths["retest_meta"], "--retest-profile",
                              paths["retest_profile"], "--db", db, "--json"], capsys)
    assert code == 0, err
    registered = json.loads(out)
    assert registered["status"] == "altered" and registered["finding"] == f
