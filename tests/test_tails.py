"""``updating.tails``: the F and chi^2 tails are scipy.stats' own, without importing it."""

import numpy as np
import pytest
import scipy.stats
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.tails import chi2_ppf, f_sf


@settings(max_examples=60, deadline=None)
@given(F=st.floats(0.0, 200.0), dfn=st.integers(1, 12), dfd=st.integers(1, 400))
def test_f_sf_is_scipy_stats(F, dfn, dfd):
    assert f_sf(F, dfn, dfd) == pytest.approx(scipy.stats.f.sf(F, dfn, dfd), rel=1e-10,
                                              abs=1e-300)


@settings(max_examples=60, deadline=None)
@given(p=st.floats(0.001, 0.999), df=st.integers(1, 40))
def test_chi2_ppf_is_scipy_stats(p, df):
    assert chi2_ppf(p, df) == pytest.approx(scipy.stats.chi2.ppf(p, df), rel=1e-10)


def test_chi2_ppf_of_an_array_and_of_no_degree():
    got = chi2_ppf(0.95, np.arange(8))
    want = scipy.stats.chi2.ppf(0.95, np.arange(8))
    assert np.isnan(got[0]) and np.isnan(chi2_ppf(0.95, 0))
    assert np.allclose(got[1:], want[1:], rtol=1e-12, atol=0.0)
    assert chi2_ppf(0.95, 1) == pytest.approx(1.959963984540054**2, rel=1e-12)  # z_0.975^2
