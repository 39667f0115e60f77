"""`batlab demo`: simulate, register, inspect, report, all from the built-in bat, on the real
pipeline: the corked re-test is found where it was drilled."""

from __future__ import annotations

import json

import numpy as np
import pytest

from batlab.cli import main
from batlab.registry import history, open_registry
from ema.io.frf_io import read_test
from tests.inspect_standins import use_standins
from updating.model.units import IN_TO_M


def test_demo_writes_everything(tmp_path, monkeypatch, capsys):
    out_dir = tmp_path / "work"
    assert main(["demo", "--out", str(out_dir), "--json"]) == 0
    cap = capsys.readouterr()
    res = json.loads(cap.out)
    assert res["serial"] == "DEMO-34A" and res["altered"] is True
    # truth: 1 in core, 10 in deep with a 1 in plug in a 34 in bat, fill 0.3
    assert res["region_in"][0] == pytest.approx(24.0, abs=1.0)
    assert res["region_in"][1] == pytest.approx(33.0, abs=1.0)
    assert res["core_diameter_in"] == pytest.approx(1.0, abs=0.15)
    assert res["fill_density_ratio"] == pytest.approx(0.3, abs=0.12)
    # the shipped calibration of the built-in bat decides (3,000 re-tests can show a chance
    # below 0.1 %), and its false-alarm count bounds that decision (its cut is the stricter)
    assert res["chance"]["decided_on"] == res["false_alarm_rate"]["decided_on"] == "calibration"
    assert res["false_alarm_rate"]["source"] == "calibration"
    assert "simulating" in cap.err and "report" in cap.err
    for name in ("profile.csv", "meta.json", "baseline.uff", "retest.uff", "registry.sqlite",
                 "report/index.html"):
        assert (out_dir / name).is_file(), name
    base, re = read_test(out_dir / "baseline.uff"), read_test(out_dir / "retest.uff")
    assert base.frf.shape == re.frf.shape == (3201, 1, 17)
    meta = json.loads((out_dir / "meta.json").read_text())
    assert np.allclose(base.x_m(base.reference_nodes), np.array(meta["points_in"]) * IN_TO_M)
    with open_registry(out_dir / "registry.sqlite") as conn:
        (insp,) = history(conn, "DEMO-34A")
    assert insp.report_path == str(out_dir / "report" / "index.html")
    assert insp.retest_name == "retest.uff"

    # a second run into the same folder replaces the demo bat and adds an inspection
    use_standins(monkeypatch)  # (quick: the numerics were checked above)
    assert main(["demo", "--out", str(out_dir)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("DEMO-34A: ALTERED") and "report:" in text
    with open_registry(out_dir / "registry.sqlite") as conn:
        assert len(history(conn, "DEMO-34A")) == 2
