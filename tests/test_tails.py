"""``updating.tails``: the F and chi^2 tails are scipy.stats' own, without importing it."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.stats
from hypothesis import example, given, settings
from hypothesis import strategies as st

from updating.tails import chi2_isf, chi2_ppf, chi2_sf, f_sf, fit_pareto


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


@settings(max_examples=60, deadline=None)
@given(x=st.floats(0.0, 200.0), df=st.integers(1, 40))
def test_chi2_sf_is_scipy_stats(x, df):
    assert chi2_sf(x, df) == pytest.approx(scipy.stats.chi2.sf(x, df), rel=1e-10, abs=1e-300)


@settings(max_examples=60, deadline=None)
@given(q=st.floats(1e-6, 0.999), df=st.integers(1, 40))
def test_chi2_isf_is_scipy_stats_and_inverts_sf(q, df):
    x = chi2_isf(q, df)
    assert x == pytest.approx(scipy.stats.chi2.isf(q, df), rel=1e-10)
    assert chi2_sf(x, df) == pytest.approx(q, rel=1e-9)


def test_the_inspection_imports_no_scipy_stats():
    """scipy.stats' import is 0.7 s of an inspection's start; neither the planes' chi^2
    tails nor a calibration's Pareto tail (``fit_pareto``) needs it."""
    code = ("import sys; import batlab.pipeline.inspection, updating.inspect.run, "
            "updating.inspect.plane_split_verdict; print('scipy.stats' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=Path(__file__).resolve().parents[1]).stdout.split()
    assert out == ["False"]


@settings(max_examples=25, deadline=None)
@example(shape=-0.625, scale=1.5, n=30, seed=0)  # scipy below -1
@example(shape=-0.5, scale=1.0, n=30, seed=0)  # ours was at the bound
@given(shape=st.floats(-0.7, 1.0), scale=st.floats(0.1, 10.0), n=st.integers(30, 400),
       seed=st.integers(0, 2**16))
def test_the_pareto_fit_is_the_maximum_scipy_stats_seeks(shape, scale, n, seed):
    """A generalized Pareto sample's fit reaches the likelihood of scipy.stats.genpareto's
    own fit (location 0) or a higher one, and their tails beyond the sample agree. Where
    scipy's fit goes below a shape of -1 the likelihood has no maximum (it grows without
    bound as the endpoint nears the largest excess): ours stops at -1, and its endpoint
    covers the sample."""
    y = scipy.stats.genpareto.rvs(shape, scale=scale, size=n, random_state=seed)
    fit = fit_pareto(y)
    c, _, s = scipy.stats.genpareto.fit(y, floc=0.0)
    theirs = float(np.sum(scipy.stats.genpareto.logpdf(y, c, 0.0, s)))
    ours = float(np.sum(scipy.stats.genpareto.logpdf(y, fit.shape, 0.0, fit.scale)))
    assert ours == pytest.approx(fit.loglik, rel=1e-9, abs=1e-9)
    assert fit.shape >= -1.0 - 1e-9
    if fit.shape < 0:
        assert fit.scale / -fit.shape >= float(np.max(y)) * (1 - 1e-12)
    if c <= -1.0:
        return
    assert ours >= theirs - 1e-6 * abs(theirs)
    if abs(ours - theirs) < 1e-6 * abs(theirs):  # the same maximum: the same tail
        far = float(np.max(y)) * 1.2
        assert fit.sf(far) == pytest.approx(float(scipy.stats.genpareto.sf(far, c, 0.0, s)),
                                            rel=2e-2, abs=1e-12)
