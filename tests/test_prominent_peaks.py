"""``ema.poles.mif.prominent_peaks``: the peaks ``scipy.signal.find_peaks`` finds with a
prominence, plateaus and ties included, without importing scipy.signal."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import find_peaks

from ema.poles.mif import local_maxima, prominent_peaks

DEMO = Path(__file__).resolve().parents[1] / "data_samples" / "smooth_bat"


@settings(max_examples=200, deadline=None)
@given(y=st.lists(st.integers(-4, 4), min_size=0, max_size=60),
       prominence=st.sampled_from([0.0, 0.5, 1.0, 2.0, 3.5]))
def test_plateaus_and_ties_as_scipy(y, prominence):
    y = np.array(y, dtype=float)
    assert np.array_equal(local_maxima(y), find_peaks(y)[0])
    assert np.array_equal(prominent_peaks(y, prominence),
                          find_peaks(y, prominence=prominence)[0])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_noisy_log_mif_as_scipy(seed):
    rng = np.random.default_rng(seed)
    f = np.linspace(1.0, 3200.0, 3201)
    s = sum(1.0 / ((f - fr) ** 2 + (0.01 * fr) ** 2) for fr in (146.0, 523.0, 1024.0, 1556.0))
    y = np.log(s * rng.lognormal(0.0, 0.2, f.size))
    for prom in (0.5, np.log(3.0), 3.0):
        assert np.array_equal(prominent_peaks(y, prom), find_peaks(y, prominence=prom)[0])
    found = f[prominent_peaks(y, 3.0)]
    for fr in (146.0, 523.0, 1024.0, 1556.0):  # each resonance stands out
        assert np.min(np.abs(found - fr)) < 0.03 * fr


def test_a_modal_fit_imports_neither_scipy_signal_nor_scipy_stats(tmp_path):
    """Their import is 0.3-0.8 s of every ``batlab inspect``; the fit needs neither."""
    code = ("import sys; from ema.io.uff import read_uff; from ema.modal_fit import fit_test; "
            f"fit = fit_test(read_uff({str(DEMO / 'retest_corked.uff')!r})); "
            "print(fit.freq_hz.size >= 4, 'scipy.stats' in sys.modules, "
            "'scipy.signal' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=Path(__file__).resolve().parents[1]).stdout.split()
    assert out == ["True", "False", "False"]
