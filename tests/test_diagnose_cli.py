"""`batlab diagnose` end to end: FRFs -> modal fit -> diagnosis, and its bad-input handling."""

import json

import numpy as np
import pytest

from batlab.cli import main
from ema.io.frf_io import write_test
from updating.model.assembly import build_model
from updating.model.mass_properties import mass_properties
from updating.model.material import Material, material_from_imperial
from updating.model.profile import make_profile, write_profile_csv
from updating.model.units import IN_TO_M, LB_TO_KG, PSI_TO_PA
from updating.simulate.virtual_bat import VirtualBat, simulate_test

X_IN = np.array([0, 0.5, 1.0, 2, 8, 14, 20, 24, 28, 33.5, 34])
D_IN = np.array([1.6, 1.6, 1.0, 0.95, 0.97, 1.2, 1.9, 2.4, 2.55, 2.55, 2.45])
POINTS_IN = np.arange(1, 34, 2).astype(float)


def write_bat(tmp_path, wood: Material, sensor_g: float, bungee: float, seed: int):
    """profile.csv, meta.json and baseline.uff of a simulated bat; returns their paths."""
    profile = make_profile(X_IN * IN_TO_M, D_IN * IN_TO_M)
    bat = VirtualBat(profile, wood, POINTS_IN * IN_TO_M, sensor_mass_kg=sensor_g * 1e-3,
                     bungee_k_n_per_m=bungee)
    weight_lb = mass_properties(build_model(profile, wood)).mass_kg / LB_TO_KG
    paths = {k: tmp_path / n for k, n in
             (("profile", "profile.csv"), ("meta", "meta.json"), ("frf", "baseline.uff"))}
    write_profile_csv(paths["profile"], profile)
    paths["meta"].write_text(json.dumps({
        "serial": "E2E-1", "species": "white ash", "nominal_E_psi": 1.74e6,
        "nominal_weight_density_lbf_in3": 0.0217, "weight_lb": weight_lb,
        "points_in": POINTS_IN.tolist()}))
    write_test(paths["frf"], simulate_test(bat, seed=seed))
    return paths


def args_of(paths) -> list[str]:
    return ["diagnose", "--profile", str(paths["profile"]), "--meta", str(paths["meta"]),
            "--frf", str(paths["frf"])]


def test_end_to_end_through_frfs(tmp_path, capsys):
    ash = material_from_imperial(1.74e6, 0.0217)
    wood = Material(ash.E_pa * 1.07, ash.rho_kg_m3 * 0.96, 14.0)
    paths = write_bat(tmp_path, wood, sensor_g=4.0, bungee=200.0, seed=11)
    code = main(args_of(paths) + ["--json", "--plots", str(tmp_path)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    out = json.loads(captured.out)  # stdout holds the JSON object alone
    names = [c["name"] for c in out["causes"]]
    assert names[0] == "shear_deformation" and "modulus" in names
    cal = out["calibrated"]
    assert cal["E_psi"] * PSI_TO_PA == pytest.approx(wood.E_pa, rel=0.03)
    assert cal["E_over_G"] == pytest.approx(14.0, rel=0.25)
    assert cal["sensor_mass_g"] == pytest.approx(4.0, abs=1.0)
    assert out["rms_error_pct"]["extended"] < 0.3 < out["rms_error_pct"]["nominal"]
    assert len(out["modes"]) >= 5 and min(m["mac"] for m in out["modes"]) > 0.99
    assert (tmp_path / "diagnose.png").stat().st_size > 1000
    # the readable form ranks the same causes
    assert main(args_of(paths)) == 0
    table = capsys.readouterr().out
    assert "shear_deformation" in table and "RMS frequency error" in table


@pytest.mark.parametrize("broken", ["profile", "meta", "frf"])
def test_bad_input_one_line_exit_2(tmp_path, capsys, broken):
    ash = material_from_imperial(1.74e6, 0.0217)
    paths = write_bat(tmp_path, Material(ash.E_pa, ash.rho_kg_m3, 13.0), 3.0, 100.0, 2)
    paths[broken].write_text("this is not a " + broken + " file\n")
    assert main(args_of(paths) + ["--json"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("batlab diagnose: error:")
    assert str(paths[broken]) in err[0]
