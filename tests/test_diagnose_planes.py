"""Diagnose with two bending planes: hide a second plane's shear modulus and a tapping angle
in simulated data, require the pipeline to find them; single-plane data say so."""

import numpy as np
import pytest

from tests.test_diagnose import HANDBOOK, POINTS, PROFILE, meta_for
from updating.correlate.measured import MeasuredModes
from updating.diagnose.run import diagnose
from updating.model.material import Material
from updating.simulate.virtual_bat import VirtualBat, simulate_modes

WOOD = Material(HANDBOOK.E_pa * 1.05, HANDBOOK.rho_kg_m3 * 0.97, 11.0)


def two_plane_modes(e_over_g_2: float, theta_deg: float, n: int = 4, seed: int = 1,
                    drop: tuple[int, ...] = ()) -> MeasuredModes:
    """Modes of a bat with plane 1 (WOOD's E/G) and plane 2 (e_over_g_2) tapped at theta:
    shapes cos(theta) phi_1 and sin(theta) phi_2; measured modes ``drop`` left out."""
    th = np.radians(theta_deg)
    parts = []
    for eg, scale, s in ((WOOD.e_over_g, np.cos(th), seed), (e_over_g_2, np.sin(th), seed + 1)):
        bat = VirtualBat(PROFILE, Material(WOOD.E_pa, WOOD.rho_kg_m3, eg), POINTS,
                         sensor_mass_kg=3e-3, bungee_k_n_per_m=300.0)
        m = simulate_modes(bat, n_modes=n, freq_noise=5e-4, shape_noise=0.005, seed=s)
        parts.append((m, scale))
    f = np.concatenate([m.freq_hz for m, _ in parts])
    y = np.hstack([m.shapes * sc for m, sc in parts])
    keep = np.setdiff1d(np.argsort(f), np.argsort(f)[list(drop)], assume_unique=True)
    keep = keep[np.argsort(f[keep])]
    m0 = parts[0][0]
    return MeasuredModes(f[keep], y[:, keep], m0.x_m, np.full(keep.size, 0.005), m0.sensor_x_m,
                         5e-4 * f[keep])


def test_two_planes_recovered_and_named():
    result = diagnose(PROFILE, meta_for(WOOD), two_plane_modes(15.0, 30.0))
    out = result.to_json_dict()
    names = [c["name"] for c in out["causes"]]
    assert "two_planes" in names
    cal = out["calibrated"]
    ref = result.reference
    assert ref.E_pa == pytest.approx(WOOD.E_pa, rel=0.01)
    assert cal["E_over_G"] == pytest.approx(11.0, rel=0.05)
    assert cal["E_over_G_plane2"] == pytest.approx(15.0, rel=0.05)
    assert cal["tap_angle_deg"] == pytest.approx(30.0, abs=3.0)
    assert cal["sensor_mass_g"] == pytest.approx(3.0, abs=1.0)
    assert result.n_split == 4 and out["unpaired_hz"] == []
    two = next(c for c in out["causes"] if c["name"] == "two_planes")
    assert two["gain_pct"] > 0.3
    assert not any("seen once" in w for w in out["warnings"])


def test_one_member_missing_is_said():
    """A pair whose second member was not found is named in the warnings, not set aside."""
    result = diagnose(PROFILE, meta_for(WOOD), two_plane_modes(15.0, 30.0, drop=(0,)))
    out = result.to_json_dict()
    assert result.n_split == 3
    assert any("seen once" in w for w in out["warnings"])
    assert out["unpaired_hz"] == []


def test_single_plane_data_do_not_claim_two_planes():
    bat = VirtualBat(PROFILE, WOOD, POINTS, sensor_mass_kg=3e-3, bungee_k_n_per_m=300.0)
    meas = simulate_modes(bat, n_modes=5, seed=4, shape_noise=0.005)
    out = diagnose(PROFILE, meta_for(WOOD), meas).to_json_dict()
    assert "two_planes" not in [c["name"] for c in out["causes"]]
    assert any("two_planes not assessed" in w for w in out["warnings"])


def test_beam_theory_corrections_hidden_and_recovered():
    """What a beam cannot represent, hidden as per-mode shifts (3D-like pattern, +-0.4 %) in
    1D-simulated modes: without the corrections diagnose states a residual floor and E is
    biased; with them `beam_theory` is named and E and E/G come back."""
    c = np.array([-0.002, 0.001, 0.004, -0.003, 0.002])
    bat = VirtualBat(PROFILE, WOOD, POINTS, sensor_mass_kg=3e-3, bungee_k_n_per_m=300.0)
    m = simulate_modes(bat, n_modes=5, seed=5, freq_noise=2e-4, shape_noise=0.005)
    meas = MeasuredModes(m.freq_hz * (1 + c), m.shapes, m.x_m, m.damping_ratio, m.sensor_x_m,
                         m.freq_std_hz)
    plain = diagnose(PROFILE, meta_for(WOOD), meas)
    assert any(w.startswith("residual floor") for w in plain.warnings)
    fixed = diagnose(PROFILE, meta_for(WOOD), meas, solid_corrections=np.vstack([c, c]))
    named = {s.name: s for s in fixed.causes}
    assert "beam_theory" in named and named["beam_theory"].gain_pct > 0.1
    assert fixed.extended.rms_pct < 0.05 < plain.extended.rms_pct
    assert fixed.reference.E_pa == pytest.approx(WOOD.E_pa, rel=0.003)
    assert fixed.reference.e_over_g == pytest.approx(WOOD.e_over_g, rel=0.03)
    assert fixed.reference.beam_theory_corrections[0] == pytest.approx(tuple(c))
    assert not any(w.startswith("residual floor") for w in fixed.warnings)


def test_solid_pass_does_not_claim_beam_theory_for_beam_data():
    """diagnose --solid on data that a 1D beam generated: the 3D corrections do not fit them,
    so beam_theory is not named and the calibration is unchanged (no false cause)."""
    from updating.diagnose.solid import diagnose_with_solid

    bat = VirtualBat(PROFILE, WOOD, POINTS, sensor_mass_kg=3e-3, bungee_k_n_per_m=300.0)
    meas = simulate_modes(bat, n_modes=4, seed=6, freq_noise=2e-4, shape_noise=0.005)
    result, corr = diagnose_with_solid(PROFILE, meta_for(WOOD), meas, n_axial=12)
    assert corr.shape[0] == 2 and np.all(np.abs(corr) < 0.05)
    assert "beam_theory" not in [c.name for c in result.causes]
    assert result.reference.E_pa == pytest.approx(WOOD.E_pa, rel=0.01)


def test_pair_in_one_peak_compared_with_the_planes_mix():
    """A roving-hammer FRF test tapped at 45 degrees (virtual rig, two planes, E/G 11 and 15):
    the first pair, split less than its peak's width, is fitted as one mode; diagnose
    compares it with the two planes' mix, assigns the split pairs' members to their planes
    the same way in every pair (the amplitudes tie), names `two_planes` and recovers E and
    both E/G."""
    from ema.modal_fit import fit_test
    from updating.correlate.measured import from_fit
    from updating.simulate.virtual_bat import simulate_test

    bat = VirtualBat(PROFILE, WOOD, POINTS, sensor_mass_kg=3e-3, bungee_k_n_per_m=150.0,
                     e_over_g_t=15.0, theta_deg=45.0)
    fit = fit_test(simulate_test(bat, seed=11))
    measured = from_fit(fit, POINTS[bat.sensor_point()])
    result = diagnose(PROFILE, meta_for(WOOD), measured, fit.suspension_freq_hz)
    out = result.to_json_dict()
    two = next(c for c in out["causes"] if c["name"] == "two_planes")
    assert two["value"]["pairs_in_one_peak"] >= 1 and two["value"]["pairs_split"] >= 3
    assert two["rms_before_pct"] - two["rms_after_pct"] > 0.3
    assert result.reference.E_pa == pytest.approx(WOOD.E_pa, rel=0.01)
    assert sorted([out["calibrated"]["E_over_G"], out["calibrated"]["E_over_G_plane2"]]) == \
        pytest.approx([11.0, 15.0], rel=0.03)
    assert out["rms_error_pct"]["extended"] < 0.05
    assert any("in one peak" in w for w in out["warnings"])


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("theta_deg", [30.0, 45.0, 60.0])
def test_plane_codes_consistent_and_one_peak_told_from_a_lone_member(seed, theta_deg):
    """Four split pairs (plane 1 the higher member, amplitudes cos / sin theta of the model's,
    1 % noise) and mode 1 seen once: plane 1 is the higher member of every pair, at 60 degrees
    too (its members the smaller); a peak holding both planes (full amplitude) is told from
    one plane's member (the larger, max(cos, sin))."""
    from updating.diagnose.plane_pairs import BOTH_IN_ONE, PLANE_1, PLANE_2, SEEN_ONCE, plane_codes

    rng = np.random.default_rng(seed)
    th = np.radians(theta_deg)
    model_norm = np.array([6.0, 4.8, 4.5, 4.4, 4.3])
    f = np.array([140.0, 500.0, 506.0, 980.0, 1000.0, 1510.0, 1557.0, 2114.0, 2206.0])
    r = np.array([0, 1, 1, 2, 2, 3, 3, 4, 4])
    amp = np.r_[1.0, np.tile([np.sin(th), np.cos(th)], 4)]  # (low: plane 2, high: plane 1)
    for first, expect in ((1.0, BOTH_IN_ONE), (max(np.cos(th), np.sin(th)), SEEN_ONCE)):
        amp[0] = first
        norm = 0.97 * model_norm[r] * amp * (1 + 0.01 * rng.standard_normal(r.size))
        code = plane_codes(f, norm, r, model_norm)
        assert code[0] == expect
        # plane 1 the stiffer (higher) member in every pair, whatever the amplitudes
        assert np.all(code[2::2] == PLANE_1) and np.all(code[1::2] == PLANE_2)
