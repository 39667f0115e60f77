"""`batlab register` + `batlab inspect` on the real pipeline (ema fit, diagnose, inspection),
run as the lab runs them (separate processes): the sample bat's corked re-test is found where
it was drilled, a re-test that only drifted is not, and the stateless and registry forms give
the same verdict."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from batlab.pipeline import jsonable
from batlab.pipeline.stored import stored_case, stored_report_inputs, with_element_map
from batlab.registry import history, open_registry
from batlab.report import MAP_JUDGED_AGAIN, regions_note
from ema.io.frf_io import write_test
from updating.inspect.details import InspectionDetails, ModePair
from updating.model.lab_input import read_meta
from updating.model.material import Material
from updating.model.profile import read_profile_csv
from updating.model.units import IN_TO_M
from updating.simulate.virtual_bat import VirtualBat, simulate_test

SAMPLE = Path("data_samples/smooth_bat")


def drifted_retest(path: Path) -> None:
    """The sample bat re-tested weeks later, unaltered: moisture +1 point, sensor re-mounted
    (the set-up of data_samples/make_samples.sh)."""
    meta = read_meta(SAMPLE / "meta.json")
    wood = meta.material.scaled(1.04, 0.97)
    bat = VirtualBat(read_profile_csv(SAMPLE / "profile.csv"),
                     Material(wood.E_pa, wood.rho_kg_m3, 13.0, wood.nu), np.sort(meta.points_m),
                     sensor_offset_m=-0.04 * IN_TO_M, sensor_mass_kg=0.003,
                     bungee_k_n_per_m=150.0, moisture_pct=1.0, rel_noise=0.005)
    write_test(path, simulate_test(bat, np.arange(0.0, 3200.5, 1.0), seed=11))


@pytest.fixture(scope="module")
def registry(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("real")
    db = tmp / "reg.sqlite"
    out = batlab(["register", "--profile", SAMPLE / "profile.csv", "--meta",
                  SAMPLE / "meta.json", "--baseline", SAMPLE / "baseline.uff", "--db", db,
                  "--json"])
    assert out["serial"] == "HX-2001" and out["reference"]["beam"] in ("euler", "timoshenko")
    drifted_retest(tmp / "drifted.uff")
    return tmp, db


def batlab(args) -> dict:
    """Run ``python -m batlab ARGS``; exit 0, one JSON object on stdout."""
    res = subprocess.run([sys.executable, "-m", "batlab", *map(str, args)], capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def assert_stored_record_reads_back(db) -> dict:
    """The latest stored verdict record's details and modes read through the typed
    ``from_json_dict`` and written again give the stored JSON exactly."""
    with open_registry(db, create=False) as conn:
        record = history(conn, "HX-2001")[-1].verdict
    details = InspectionDetails.from_json_dict(record["details"])
    assert details.fit is not None and details.p_value == record["details"]["p_value"]
    assert jsonable(details.to_json_dict()) == record["details"]
    assert [ModePair.from_json_dict(m).to_json_dict() for m in record["modes"]] == \
        record["modes"]
    return record


def test_corked_retest_found_in_place(registry):
    tmp, db = registry
    out = batlab(["inspect", "--serial", "HX-2001", SAMPLE / "retest_corked.uff",
                        "--db", db, "--json"])
    assert out["altered"] is True
    a, b = out["region_in"]
    assert a == pytest.approx(24.0, abs=1.0) and b == pytest.approx(33.0, abs=1.0)
    assert out["core_diameter_in"] == pytest.approx(1.0, abs=0.15)
    assert out["fill_density_ratio"] == pytest.approx(0.3, abs=0.12)
    x0 = np.array([e["x0_in"] for e in out["elements"]])
    x1 = np.array([e["x1_in"] for e in out["elements"]])
    assert x0[0] == pytest.approx(0.0, abs=1e-6) and x1[-1] == pytest.approx(34.0, abs=1e-3)
    assert np.allclose(x0[1:], x1[:-1])
    alpha = np.array([e["alpha"] for e in out["elements"]])
    inside = (x0 >= 24.5) & (x1 <= 32.5)
    outside = (x1 <= 22.0)
    assert alpha[inside].mean() < -0.05  # mass removed where the core is
    assert np.all(np.abs(alpha[outside]) < 0.2 * abs(alpha[inside].mean()))

    stateless = batlab(["inspect", "--profile", SAMPLE / "profile.csv", "--meta",
                              SAMPLE / "meta.json", "--baseline", SAMPLE / "baseline.uff",
                              "--retest", SAMPLE / "retest_corked.uff", "--json",
                              "--db", db])  # the calibrations it reads: the same registry's
    assert stateless == out
    record = assert_stored_record_reads_back(db)
    details = InspectionDetails.from_json_dict(record["details"])
    assert details.msso.result is None and details.msso.error is None  # no report asked


def test_element_map_drawn_when_a_report_asks(registry):
    """An inspection without a report stores no MSSO element map; a report of it judges the
    stored tests again and draws the map an inspection with a report stores, the same to
    the digit (but its time), and says so. A stored verdict the second judgement does not
    reproduce gets no map, and says why. A retest.json's conditions are stored for that
    second judgement."""
    tmp, db = registry
    retest = SAMPLE / "retest_corked.uff"
    batlab(["inspect", "--serial", "HX-2001", retest, "--db", db, "--again", "--json"])
    with open_registry(db, create=False) as conn:
        inputs = stored_report_inputs(conn, "HX-2001")
        case = stored_case(conn, "HX-2001")[2]
        bare = history(conn, "HX-2001")[-1]
    assert bare.verdict["details"]["msso"] == {}
    drawn = inputs.verdict["details"]["msso"]
    assert drawn["region_m"] is not None and len(drawn["alpha"]) > 10
    assert regions_note(inputs).startswith(MAP_JUDGED_AGAIN)
    batlab(["inspect", "--serial", "HX-2001", retest, "--db", db, "--again", "--json",
            "-o", tmp / "rep"])
    with open_registry(db, create=False) as conn:
        stored = history(conn, "HX-2001")[-1].verdict
    untimed = [{k: v for k, v in m.items() if k != "time_s"}
               for m in (stored["details"]["msso"], drawn)]
    assert untimed[0] == untimed[1]
    # a verdict this batlab does not reproduce (here: its status changed) gets no map
    other = {**bare.verdict, "status": "not_altered"}
    again = with_element_map(replace(inputs, verdict=other), case, bare.inputs)
    assert "no map is drawn" in again.verdict["details"]["msso"]["error"]
    (tmp / "retest.json").write_text(json.dumps({"weight_lb": 1.90, "temperature_c": 21.0}))
    batlab(["inspect", "--serial", "HX-2001", tmp / "drifted.uff", "--db", db,
            "--retest-meta", tmp / "retest.json", "--json"])
    with open_registry(db, create=False) as conn:
        kept = history(conn, "HX-2001")[-1].inputs
    assert kept["retest_meta"] is True and kept["retest_conditions"]["temperature_c"] == 21.0
    assert kept["retest_conditions"]["weight_kg"] == pytest.approx(1.90 * 0.45359237)


def test_drifted_retest_is_not_altered(registry):
    tmp, db = registry
    out = batlab(["inspect", "--serial", "HX-2001", tmp / "drifted.uff", "--db", db,
                        "--json"])
    assert out["altered"] is False
    assert out["region_in"] is None and out["core_diameter_in"] is None
    assert out["fill_density_ratio"] is None
    assert len(out["elements"]) > 10
    assert_stored_record_reads_back(db)
