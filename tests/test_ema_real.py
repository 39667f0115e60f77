"""`batlab fit` on real measured FRFs (data_samples/real, see its README): no crash, no silent
empty result, and physics the source implies: the six modes of the pyuff beam measurement are
a free-free uniform beam's bending modes, whose frequency ratios are (beta_r L)^2 /
(beta_1 L)^2 with cos(beta L) cosh(beta L) = 1 (Euler-Bernoulli); the vibration_toolbox
analyser exports (one noisy FRF each, no driving point) give the frequencies the source's own
examples state."""

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.io import loadmat
from scipy.optimize import brentq

from batlab.cli import main
from ema.io.frf_io import read_test
from ema.modal_fit import fit_test

REAL = Path(__file__).resolve().parents[1] / "data_samples" / "real" / "pyuff_measurement"
VTB = REAL.parent / "vibration_toolbox"


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


def _fit_json(capsys, *args: str) -> tuple[int, dict, str]:
    code = main(["fit", *args, "--json"])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if out.out else {}), out.err


def test_vibration_toolbox_case1_mode_and_its_warnings(capsys):
    """One FRF, coherence about 0.3-0.4, 3.2 s records: the dominant mode is at the 212.09 Hz
    the source's own SDOF fit states (its ``sdof_cf`` example), and the fit says what is weak
    about it (low coherence; the response has not decayed; damping finer than the lines)."""
    code, doc, err = _fit_json(capsys, str(VTB / "case1.uff"))
    assert code == 0
    f = np.array([m["frequency_hz"] for m in doc["modes"]])
    k = int(np.argmin(np.abs(f - 212.09)))
    assert abs(f[k] / 212.09 - 1) < 5e-4
    assert doc["scaled"] is False  # no driving point recorded: unscaled shapes, said so
    warnings = " ".join(doc["modes"][k]["warnings"])
    assert "low coherence" in warnings
    assert "low coherence" in err
    # the sub-band 150-300 Hz finds the same mode (band consistency on measured data)
    code, sub, _ = _fit_json(capsys, str(VTB / "case1.uff"), "--band", "150", "300")
    fs = np.array([m["frequency_hz"] for m in sub["modes"]])
    assert code == 0 and fs.size and np.min(np.abs(fs / f[k] - 1)) < 5e-4
    for g in fs:
        assert np.min(np.abs(f / g - 1)) < 5e-4


def test_vibration_toolbox_case2_empty_fit_says_why_and_where(capsys):
    """A noisier record (coherence mostly < 0.5): at the default support threshold no mode is
    accepted, and the fit says so (not silently): the rejections are counted and the note
    names the tallest sum-MIF peaks, among them the resonance at 192.59 Hz the source's own
    MDOF fit states (its ``mdof_cf`` example); a lower --min-snr then finds it."""
    code, doc, err = _fit_json(capsys, str(VTB / "case2.uff"))
    assert code == 0 and doc["modes"] == []
    note = next(n for n in doc["notes"] if n.startswith("no mode"))
    assert "rejected" in note and "192.5" in note and "--min-snr" in note
    assert "no mode" in err
    code, low, _ = _fit_json(capsys, str(VTB / "case2.uff"), "--min-snr", "2")
    f = np.array([m["frequency_hz"] for m in low["modes"]])
    assert code == 0 and np.min(np.abs(f / 192.59 - 1)) < 1e-3


@pytest.mark.parametrize("name", ["case1", "case2"])
def test_vibration_toolbox_uff_keeps_the_source_values(name):
    """convert.py's UFF holds the source's FRF and coherence as they are (coherence above 1,
    an estimator artefact in 5 lines of case1, written as 1)."""
    mat = loadmat(VTB / f"{name}.mat")
    test = read_test(VTB / f"{name}.uff", require_driving=False)
    np.testing.assert_array_equal(test.freq_hz, mat["Freq_domain"].ravel().astype(float))
    np.testing.assert_allclose(test.frf[:, 0, 0], mat["Hf_chan_2"].ravel(), rtol=1e-12, atol=0)
    np.testing.assert_allclose(test.coherence[:, 0, 0],
                               np.clip(mat["Hf_coh_chan_2"].ravel().astype(float), 0, 1),
                               rtol=1e-7)
