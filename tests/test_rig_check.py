"""Rig check on a reference bar: sections, the bar file, and hidden rig faults flagged."""

import json
from dataclasses import replace

import numpy as np
import pytest

from batlab.cli import main
from ema.io.frf_io import write_test
from updating.correlate.measured import MeasuredModes
from updating.diagnose.rig_check import check_rig
from updating.model.bar import bar_from_dict, read_bar_json
from updating.model.material import Material
from updating.model.modes import model_modes
from updating.model.profile import make_profile
from updating.simulate.virtual_bat import VirtualBat, simulate_modes, simulate_test

STEEL = {"E_gpa": 200.0, "density_kg_m3": 7850.0, "nu": 0.29}
ROUND = {"material": STEEL, "length_mm": 600.0, "section": {"shape": "round",
                                                            "diameter_mm": 25.0},
         "sensor_mass_g": 2.0}
POINTS = np.arange(20.0, 600.0, 40.0) * 1e-3


def test_sections_and_slender_bar_frequencies():
    """Rectangular and tube sections by their formulas; a slender bar (L/h = 120) within
    0.2 % below Euler-Bernoulli's free-free beta L = 4.7300, 7.8532, 10.9956 (shear and
    rotary inertia lower it by ~(h/L)^2)."""
    rect = bar_from_dict({"material": STEEL, "length_m": 0.6,
                          "section": {"shape": "rectangular", "width_mm": 25, "height_mm": 5}})
    s = rect.section()
    assert float(s.ei) == pytest.approx(200e9 * 0.025 * 0.005**3 / 12)
    assert float(s.rhoa) == pytest.approx(7850 * 0.025 * 0.005)
    f = model_modes(rect.model(60), 8).elastic().freq_hz[:3]
    eb = np.array([4.7300, 7.8532, 10.9956]) ** 2 / (2 * np.pi * 0.36) * np.sqrt(
        float(s.ei) / float(s.rhoa))
    assert np.allclose(f, eb, rtol=2e-3) and np.all(f < eb)
    tube = bar_from_dict({"material": STEEL, "length_mm": 600, "section": {
        "shape": "tube", "diameter_mm": 25.4, "inner_diameter_mm": 19.0}})
    assert float(tube.section().ei) == pytest.approx(
        200e9 * np.pi / 64 * (0.0254**4 - 0.019**4))
    assert tube.mass_kg == pytest.approx(7850 * np.pi / 4 * (0.0254**2 - 0.019**2) * 0.6)


@pytest.mark.parametrize("change, message", [
    ({"length_mm": None, "length_in": 24}, "length_mm or length_m"),
    ({"section": {"shape": "tube", "diameter_mm": 20, "inner_diameter_mm": 25}},
     "inner_diameter"),
    ({"section": {"shape": "hexagon"}}, "section.shape"),
    ({"material": {"E_gpa": -1, "density_kg_m3": 7850}}, "E_gpa"),
])
def test_bad_bar_files_name_the_key(tmp_path, change, message):
    d = {**ROUND, **{k: v for k, v in change.items() if v is not None}}
    d = {k: v for k, v in d.items() if change.get(k, 0) is not None}
    path = tmp_path / "bar.json"
    path.write_text(json.dumps(d))
    with pytest.raises(ValueError, match=message):
        read_bar_json(path)


def virtual_bar(E_pa=200e9, zeta=0.001, **kw) -> VirtualBat:
    """The round bar on the virtual rig (free-free, 2 g accelerometer near the end)."""
    profile = make_profile(np.array([0.0, 0.6]), np.array([0.025, 0.025]))
    wood = Material(E_pa, 7850.0, 2 * 1.29, 0.29, "hutchinson")
    return VirtualBat(profile, wood, POINTS, sensor_mass_kg=2e-3, zeta1=zeta, zeta_exponent=0.0,
                      element_length_m=0.005, **kw)


def measured(bat: VirtualBat, sensitivity: float = 1.0, seed: int = 1) -> MeasuredModes:
    m = simulate_modes(bat, n_modes=5, freq_noise=3e-4, shape_noise=0.005, seed=seed)
    return MeasuredModes(m.freq_hz, m.shapes * np.sqrt(sensitivity), m.x_m, m.damping_ratio,
                         m.sensor_x_m, m.freq_std_hz)


def verdicts(result) -> dict:
    return {c.name: c.ok for c in result.checks}


def test_good_rig_passes_and_hidden_faults_are_flagged():
    bar = bar_from_dict(ROUND)
    good = check_rig(bar, measured(virtual_bar()))
    assert good.ok, good.to_json_dict()
    assert np.max(np.abs(good.measured_hz / good.model_hz - 1)) < 2e-3
    # the bar is not what the file says: E 4 % lower than stated
    soft = check_rig(bar, measured(virtual_bar(E_pa=192e9)))
    assert verdicts(soft) == {**verdicts(good), "frequencies": False}
    # hammer x accelerometer sensitivity 25 % off: FRFs 1.25 x, shapes sqrt(1.25) x
    loud = check_rig(bar, measured(virtual_bar(), sensitivity=1.25))
    assert verdicts(loud) == {**verdicts(good), "amplitude_scale": False}
    scale = next(c for c in loud.checks if c.name == "amplitude_scale").value
    assert scale == pytest.approx(1.25, rel=0.02)
    # a clamp or a hand on the bar: damping 2 %
    damped = check_rig(bar, measured(virtual_bar(zeta=0.02)))
    assert verdicts(damped) == {**verdicts(good), "damping": False}


def test_check_rig_command_end_to_end(tmp_path, capsys):
    """FRFs of the virtual rig -> ema fit -> check; exit 0 when it matches, 1 when the bar
    file's E is wrong, 2 with one line on stderr for a bad file."""
    write_test(tmp_path / "bar.uff", simulate_test(virtual_bar(), seed=3))
    (tmp_path / "bar.json").write_text(json.dumps(ROUND))
    args = ["check-rig", "--bar", str(tmp_path / "bar.json"), "--frf", str(tmp_path / "bar.uff")]
    assert main(args + ["--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["ok"] and len(out["modes"]) >= 4
    # the same test with the FRFs 25 % too large (a sensitivity entered wrong)
    test = simulate_test(virtual_bar(), seed=3)
    write_test(tmp_path / "loud.uff", replace(test, frf=1.25 * test.frf))
    assert main(["check-rig", "--bar", str(tmp_path / "bar.json"), "--frf",
                 str(tmp_path / "loud.uff"), "--json"]) == 1
    checks = {c["name"]: c for c in json.loads(capsys.readouterr().out)["checks"]}
    assert checks["amplitude_scale"]["value"] == pytest.approx(1.25, rel=0.02)
    assert not checks["mass_line"]["ok"] and checks["frequencies"]["ok"]
    assert {c["name"] for c in out["checks"]} >= {"frequencies", "damping", "amplitude_scale"}
    wrong = {**ROUND, "material": {**STEEL, "E_gpa": 210.0}}
    (tmp_path / "wrong.json").write_text(json.dumps(wrong))
    assert main(["check-rig", "--bar", str(tmp_path / "wrong.json"), "--frf",
                 str(tmp_path / "bar.uff")]) == 1
    assert "FAIL  frequencies" in capsys.readouterr().out
    (tmp_path / "bad.json").write_text(json.dumps({**ROUND, "section": {"shape": "round"}}))
    assert main(["check-rig", "--bar", str(tmp_path / "bad.json"), "--frf",
                 str(tmp_path / "bar.uff")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.json" in err[0] and "diameter" in err[0]
