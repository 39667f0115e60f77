"""Diagnose: sensitivities, the nominal case, the contract's JSON, the calibrated reference."""

import json

import numpy as np
import pytest

from updating.diagnose.model import (
    CAUSES,
    Setup,
    State,
    free_parameters,
    from_vector,
    modal_sensitivities,
)
from updating.diagnose.model import to_vector as vector_of
from updating.diagnose.run import diagnose
from updating.model.assembly import build_model
from updating.model.lab_input import BatMeta
from updating.model.mass_properties import mass_properties
from updating.model.material import Material, paper_material
from updating.model.modes import model_modes
from updating.model.profile import make_profile, paper_profile
from updating.model.reference import BatReference
from updating.model.units import IN_TO_M, LBF_IN3_TO_KG_M3, PSI_TO_PA
from updating.simulate.virtual_bat import VirtualBat, simulate_modes

X_IN = np.array([0, 0.5, 1.0, 2, 8, 14, 20, 24, 28, 33.5, 34])
D_IN = np.array([1.6, 1.6, 1.0, 0.95, 0.97, 1.2, 1.9, 2.4, 2.55, 2.55, 2.45])
PROFILE = make_profile(X_IN * IN_TO_M, D_IN * IN_TO_M)
POINTS = np.arange(1, 34, 2) * IN_TO_M
HANDBOOK = Material(12.0e9, 660.0)


def meta_for(material: Material, profile=PROFILE, points=POINTS, weight=True) -> BatMeta:
    """meta.json of a bat whose true wood is ``material`` (the scale weighs the true bat)."""
    w = mass_properties(build_model(profile, material)).mass_kg if weight else None
    return BatMeta("T-1", "ash", HANDBOOK, w, points)


def test_modal_sensitivities_match_finite_differences():
    setup = Setup(PROFILE, HANDBOOK, None, POINTS, POINTS[-1])
    active = frozenset(CAUSES)
    state = State(11e9, 640.0, 13.0, 3e-3, 300.0)
    names = free_parameters(active, setup)
    x = vector_of(state, names)
    sol = modal_sensitivities(setup, active, state, 6, names)
    for j, name in enumerate(names):
        h = 1e-5 * max(1.0, abs(x[j]))
        up, dn = x.copy(), x.copy()
        up[j] += h
        dn[j] -= h
        s_up = modal_sensitivities(setup, active, from_vector(state, names, up), 6)
        s_dn = modal_sensitivities(setup, active, from_vector(state, names, dn), 6)
        fd = (np.log(s_up.elastic_hz) - np.log(s_dn.elastic_hz)) / (2 * h)
        sign_up = np.sign(np.sum(s_up.shapes * sol.shapes, axis=0))
        sign_dn = np.sign(np.sum(s_dn.shapes * sol.shapes, axis=0))
        fd_shape = (s_up.shapes * sign_up - s_dn.shapes * sign_dn) / (2 * h)
        # E/G: k_shear = kGA dK/dkGA is exact for uniform elements only (tapered: ~0.2 %)
        shear = name in ("ln_e_over_g", "ln_g_ratio")
        tol = 5e-3 if shear else 1e-5
        assert np.allclose(sol.dlnf[j], fd, rtol=tol, atol=tol * np.abs(fd).max()), name
        tol_shape = 3e-2 if shear else 2e-3
        assert np.abs(sol.dshapes[j] - fd_shape).max() <= tol_shape * np.abs(fd_shape).max(), name


def test_data_from_the_nominal_model_names_no_cause():
    """The paper's own model as the 'test': nothing to explain, the reference is the nominal."""
    profile, wood = paper_profile(), paper_material()
    points = np.arange(1, 34, 2) * IN_TO_M
    bat = VirtualBat(profile, wood, points, beam="euler", element_length_m=IN_TO_M)
    meas = simulate_modes(bat, n_modes=6, freq_noise=0.0, shape_noise=0.0)
    meta = BatMeta("P", "birch", wood, mass_properties(build_model(profile, wood)).mass_kg,
                   points)
    result = diagnose(profile, meta, meas)
    assert result.nominal.rms_pct < 1e-6
    assert result.causes == ()
    assert result.reference.E_pa == pytest.approx(wood.E_pa, rel=1e-6)
    assert result.reference.beam == "euler" and result.reference.sensor_mass_kg < 1e-4


def test_contract_json_and_reference_reproduce_the_extended_model():
    wood = Material(HANDBOOK.E_pa * 1.08, HANDBOOK.rho_kg_m3 * 0.95, 12.0)
    bat = VirtualBat(PROFILE, wood, POINTS, sensor_mass_kg=4e-3, bungee_k_n_per_m=300.0)
    meas = simulate_modes(bat, n_modes=6, seed=3, shape_noise=0.005)
    result = diagnose(PROFILE, meta_for(wood), meas)
    out = json.loads(json.dumps(result.to_json_dict()))
    assert set(out) >= {"modes", "rms_error_pct", "causes", "calibrated"}
    assert all(set(m) >= {"measured_hz", "nominal_hz", "extended_hz", "mac"} for m in out["modes"])
    assert set(out["rms_error_pct"]) == {"nominal", "extended"}
    assert set(out["calibrated"]) >= {"E_psi", "E_over_G", "weight_density_lbf_in3",
                                      "sensor_mass_g"}
    value_keys = {"modulus": {"E_psi"}, "shear_deformation": {"E_over_G"},
                  "sensor_mass": {"mass_g"}, "density": {"weight_density_lbf_in3"},
                  "suspension": {"k_n_per_m"}, "rotary_inertia": set()}
    gains = [c["gain_pct"] for c in out["causes"]]
    assert gains == sorted(gains, reverse=True) and min(gains) >= 0.05
    for c in out["causes"]:
        assert c["name"] in CAUSES
        if c["name"] in value_keys:
            assert set(c["value"]) == value_keys[c["name"]]
    # the gains are measured: along the selection they add up to the drop of the RMS error
    path = [s.gain_pct for s in result.steps if s.role != "rejected"]
    assert sum(path) == pytest.approx(out["rms_error_pct"]["nominal"]
                                      - out["rms_error_pct"]["extended"], abs=0.01)
    cal = out["calibrated"]
    assert cal["E_psi"] * PSI_TO_PA == pytest.approx(wood.E_pa, rel=0.03)
    assert cal["weight_density_lbf_in3"] * LBF_IN3_TO_KG_M3 == pytest.approx(wood.rho_kg_m3,
                                                                            rel=1e-3)
    # the stored reference rebuilds the calibrated model: same frequencies
    ref = BatReference.from_dict(out["reference"])
    fine = "geometry" in result.extended.active
    model = ref.build(PROFILE, POINTS if fine else (),
                      element_length_m=0.5 * IN_TO_M if fine else None)
    f = model_modes(model, 12).freq_hz[2:]
    ext = np.array([m["extended_hz"] for m in out["modes"]])
    assert np.allclose(f[result.model_index], ext, rtol=1e-9)


def test_no_weight_density_comes_from_the_mass_normalised_shapes():
    wood = Material(HANDBOOK.E_pa * 0.9, HANDBOOK.rho_kg_m3 * 1.07, 14.0)
    bat = VirtualBat(PROFILE, wood, POINTS, sensor_mass_kg=3e-3, bungee_k_n_per_m=200.0)
    meas = simulate_modes(bat, n_modes=6, seed=5, shape_noise=0.005)
    result = diagnose(PROFILE, meta_for(wood, weight=False), meas)
    assert result.reference.rho_kg_m3 == pytest.approx(wood.rho_kg_m3, rel=0.02)
    assert result.reference.E_pa == pytest.approx(wood.E_pa, rel=0.03)


def test_suspension_modes_give_the_bungee_stiffness():
    wood = Material(HANDBOOK.E_pa, HANDBOOK.rho_kg_m3, 13.0)
    bat = VirtualBat(PROFILE, wood, POINTS, sensor_mass_kg=3e-3, bungee_k_n_per_m=400.0)
    meas = simulate_modes(bat, n_modes=6, seed=6, shape_noise=0.005)
    rigid_hz = model_modes(bat.truth_model(), 4).freq_hz[:2] * np.array([1.004, 0.996])
    result = diagnose(PROFILE, meta_for(wood), meas, suspension_hz=rigid_hz)
    assert result.reference.bungee_k_n_per_m == pytest.approx(400.0, rel=0.03)


def test_bad_measured_input_is_one_clear_error():
    wood = Material(HANDBOOK.E_pa, HANDBOOK.rho_kg_m3, 13.0)
    bat = VirtualBat(PROFILE, wood, POINTS)
    meas = simulate_modes(bat, n_modes=4, seed=1)
    outside = type(meas)(meas.freq_hz, meas.shapes, meas.x_m + 0.2, meas.damping_ratio,
                         meas.sensor_x_m)
    with pytest.raises(ValueError, match="outside the bat"):
        diagnose(PROFILE, meta_for(wood), outside)
