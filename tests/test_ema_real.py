"""`batlab fit` on real measured FRFs (data_samples/real, see its README): no crash, no silent
empty result, and physics the source implies: the six modes of the pyuff beam measurement are
a free-free uniform beam's bending modes, whose frequency ratios are (beta_r L)^2 /
(beta_1 L)^2 with cos(beta L) cosh(beta L) = 1 (Euler-Bernoulli)."""

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from batlab.cli import main
from ema.fit import fit_test
from ema.io.frf_io import read_test

REAL = Path(__file__).resolve().parents[1] / "data_samples" / "real" / "pyuff_measurement"


def _free_free_ratios(n: int) -> np.ndarray:
    """(beta_r L)^2 / (beta_1 L)^2 for the first n roots of cos x cosh x = 1 (x > 0)."""
    roots = [brentq(lambda x: np.cos(x) * np.cosh(x) - 1, (r + 0.5) * np.pi - 0.3,
                    (r + 0.5) * np.pi + 0.3) for r in range(1, n + 1)]
    return (np.array(roots) / roots[0]) ** 2


@pytest.fixture(scope="module")
def full():
    return fit_test(read_test(REAL / "test.uff"))


def test_beam_modes_have_free_free_beam_ratios(full):
    assert full.freq_hz.size == 6
    np.testing.assert_allclose(full.freq_hz / full.freq_hz[0], _free_free_ratios(6), rtol=0.003)
    assert np.all((full.damping_ratio > 0) & (full.damping_ratio < 0.002))
    assert np.all(full.mpc > 0.98)
    assert full.synthesis_error_total < 0.05
    # 2 zeta f < 1 Hz for every mode: the damping is finer than the lines, and said so
    assert all(any(w.startswith("under-resolved damping") for w in ws) for ws in full.warnings)


@pytest.mark.parametrize("name", ["one_frf", "two_nodes", "no_driving_point"])
def test_subsets_give_the_same_modes(full, name, capsys):
    assert main(["fit", str(REAL / f"{name}.uff"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    f = np.array([m["frequency_hz"] for m in doc["modes"]])
    np.testing.assert_allclose(f, full.freq_hz, rtol=2e-4)
    assert doc["scaled"] is (name != "no_driving_point")


def test_shapes_agree_between_subsets(full):
    """Reciprocity/consistency: the two-node test's mass-normalised shapes are the full test's
    at those nodes (the same driving point, fewer impacts)."""
    two = fit_test(read_test(REAL / "two_nodes.uff"))
    np.testing.assert_allclose(two.real_shapes, full.real_shapes[:2], rtol=0.05, atol=0.02 *
                               np.abs(full.real_shapes).max())


@settings(max_examples=8, deadline=None, derandomize=True)
@given(lo_hz=st.floats(20.0, 750.0), width_hz=st.floats(150.0, 500.0))
def test_sub_band_modes_are_the_full_band_modes(full, lo_hz, width_hz):
    """Band consistency on measured data: every mode fitted in a sub-band is a mode of the
    full-band fit (0.05 %), and every full-band mode at least 5 % inside the sub-band's edges
    is found in the sub-band."""
    hi_hz = min(lo_hz + width_hz, 1000.0)
    sub = fit_test(read_test(REAL / "test.uff"), band_hz=(lo_hz, hi_hz))
    for f in sub.freq_hz:
        assert np.min(np.abs(full.freq_hz / f - 1)) < 5e-4, (lo_hz, hi_hz, f)
    inner = full.freq_hz[(full.freq_hz > 1.05 * lo_hz) & (full.freq_hz < hi_hz / 1.05)]
    for f in inner:
        assert sub.freq_hz.size and np.min(np.abs(sub.freq_hz / f - 1)) < 5e-4, (lo_hz, hi_hz, f)


def test_band_past_the_data_is_clipped_with_a_note(full):
    wide = fit_test(read_test(REAL / "test.uff"), band_hz=(20.0, 1200.0))
    assert any("clipped to 20-1000 Hz" in n for n in wide.notes)
    np.testing.assert_allclose(wide.freq_hz, full.freq_hz, rtol=1e-6)
