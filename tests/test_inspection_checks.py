"""The checks before a verdict (units, identity, coverage, pairing), the two-plane merge and
retest.json: each slip is recognised with its reason, and the drift of a real bat is not."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.correlate.measured import MeasuredModes
from updating.correlate.planes import merge_plane_pairs
from updating.inspect.checks import (
    amplitude_reason,
    coverage_reason,
    identity_reason,
    pairing_reason,
)
from updating.inspect.retest_meta import read_retest_meta
from updating.model.units import IN_TO_M, LB_TO_KG

X = np.arange(1.0, 33.0, 2.0) * IN_TO_M
L = 33.0 * IN_TO_M
F = np.array([150.0, 560.0, 1000.0, 1700.0, 2500.0, 3100.0])


def beam_shapes(n_points: int = X.size, m: int = F.size) -> np.ndarray:
    """Free-free-like bending shapes at the points (cosines), scaled as 1/sqrt(kg)."""
    x = np.linspace(0.0, 1.0, n_points)[:, None]
    k = np.arange(1, m + 1)[None, :]
    return 2.0 * np.cos(np.pi * (k + 0.5) * x)


@settings(max_examples=20, deadline=None, derandomize=True)
@given(moisture_pt=st.floats(-2.5, 2.5), noise=st.floats(0.0, 0.02),
       seed=st.integers(0, 10**6))
def test_drift_of_one_bat_passes_every_check(moisture_pt, noise, seed):
    """Moisture scales mass-normalised shapes by 1/sqrt(s_rho) and f by sqrt(s_E/s_rho);
    with shape noise up to 2 % none of the checks objects."""
    rng = np.random.default_rng(seed)
    s_e, s_rho = 1 - 0.02 * moisture_pt, 1 + 0.01 * moisture_pt
    psi = beam_shapes()
    psi_r = psi / np.sqrt(s_rho) * (1 + noise * rng.standard_normal(psi.shape))
    assert amplitude_reason(psi, psi_r, F) is None
    dlnf = np.full(F.size, 0.5 * np.log(s_e / s_rho))
    assert identity_reason(dlnf, np.log(s_rho)) is None
    assert coverage_reason(X, L) is None
    assert pairing_reason(F.size) is None


def test_units_slips_are_named():
    psi = beam_shapes()
    # g/N labelled SI: the FRF divided by 9.81, modal constants too, shapes by sqrt(9.81)
    why = amplitude_reason(psi, psi / np.sqrt(9.81), F)
    assert why and "9.81" in why and "units" in why
    # receptance labelled accelerance: the FRF times 1/w^2 -> shapes times 1/w
    w = 2 * np.pi * F
    why = amplitude_reason(psi, psi * (w[0] / w)[None, :], F)
    assert why and "receptance" in why and "f^-2" in why
    # a sensitivity slip: FRF x 1.3 is flagged (shapes x 1.14), x 1.1 is within what a
    # core can do to the amplitudes (shapes x 1.05) and is left to the fit
    assert "1.3 times" in amplitude_reason(psi, psi * np.sqrt(1.3), F)
    assert amplitude_reason(psi, psi * np.sqrt(1.1), F) is None
    flipped = psi.copy()
    flipped[:, 2] *= -1
    assert "sign" in amplitude_reason(psi, flipped, F)


def test_another_bat_is_not_the_same_bat():
    assert "frequencies differ" in identity_reason(np.full(6, np.log(1.10)), None)
    assert "weight differs" in identity_reason(np.zeros(6), np.log(0.7))
    # a big cork core takes out ~13 % of the weight: still the same bat
    assert identity_reason(np.full(6, 0.02), np.log(0.87)) is None


def test_layout_without_barrel_points_is_named():
    """``batlab model --n-points`` of old: nothing between 16 and 34 in but the end face."""
    x = np.append(np.arange(1.0, 16.0, 2.0), 33.9) * IN_TO_M
    why = coverage_reason(x, 34.0 * IN_TO_M)
    assert why and "barrel" in why
    assert coverage_reason(np.arange(1.0, 34.0, 2.0) * IN_TO_M, 34.0 * IN_TO_M) is None


def test_too_few_pairs_is_a_reason_not_an_error():
    why = pairing_reason(1)
    assert why.startswith("only 1 modes pair") and "re-test" in why


def test_two_plane_pairs_merge_into_one_mode():
    """psi_R = cos(t) phi, psi_T = sin(t) phi at f_R, f_T: one mode phi at the
    cos^2/sin^2-weighted frequency; isolated modes untouched."""
    phi = beam_shapes(m=3)
    t = np.deg2rad(35.0)
    f_r, f_t = 560.0, 560.0 * 1.013
    shapes = np.column_stack([phi[:, 0], np.cos(t) * phi[:, 1], -np.sin(t) * phi[:, 1],
                              phi[:, 2]])
    modes = MeasuredModes(np.array([150.0, f_r, f_t, 1000.0]), shapes, X,
                          np.array([0.005, 0.006, 0.007, 0.008]), X[-1],
                          np.array([0.01, 0.02, 0.03, 0.04]))
    out = merge_plane_pairs(modes)
    assert out.freq_hz.size == 3
    assert out.freq_hz[1] == pytest.approx(np.cos(t) ** 2 * f_r + np.sin(t) ** 2 * f_t)
    assert np.allclose(out.shapes[:, 1], phi[:, 1])
    assert np.allclose(out.shapes[:, [0, 2]], phi[:, [0, 2]])
    assert out.freq_std_hz[1] == 0.03 and out.freq_hz[2] == 1000.0
    # modes far apart or of different shape are not pairs
    assert merge_plane_pairs(MeasuredModes(F[:3], beam_shapes(m=3), X, np.full(3, 0.005),
                                           X[-1])).freq_hz.size == 3


def test_retest_meta_read_in_si(tmp_path):
    p = tmp_path / "retest.json"
    p.write_text(json.dumps({"weight_lb": 2.2388, "accelerometer_mass_g": 4.1,
                             "temperature_c": 24.0, "tested_on": "2026-05-02", "x": 1}))
    c = read_retest_meta(p)
    assert c.weight_kg == pytest.approx(2.2388 * LB_TO_KG)
    assert c.sensor_mass_kg == pytest.approx(4.1e-3)
    assert (c.temperature_c, c.tested_on) == (24.0, "2026-05-02")
    p.write_text("{}")
    assert read_retest_meta(p).weight_kg is None
    p.write_text('{"weight_lb": true}')
    with pytest.raises(ValueError, match="retest.json: key 'weight_lb' must be a number"):
        read_retest_meta(p)
    with pytest.raises(ValueError, match="no such file"):
        read_retest_meta(tmp_path / "nope.json")
