"""The MSSO element map of an inspection: where the change is, independent of the core fit.

Seeded random bats from the virtual fleet (a truth richer than the reference, moisture drift,
a re-mounted accelerometer, 1-2 % shape noise): the map's largest changes lie on the truly
cored elements, an unaltered bat's map stays within its noise, and the verdict carries both
the fitted-core factors (the contract's elements) and the map.
"""

import numpy as np
import pytest

from updating.inspect.run import inspect_retest
from updating.msso.core_elements import core_element_factors
from updating.simulate.fleet import case_modes, random_case


def _inspect(seed, kind):
    rng = np.random.default_rng(seed)
    case = random_case(rng, kind)
    base, re = case_modes(case, rng)
    return case, inspect_retest(case.profile, case.reference, base, re)


def _true_factors(case, v):
    model = case.reference.build(case.profile, v.element_x0_m[1:])
    return core_element_factors(model, case.core)


@pytest.mark.parametrize("seed,kind", [(12, "cork"), (13, "heavy"), (16, "cork")])
def test_map_peaks_in_the_cored_region(seed, kind):
    case, v = _inspect(seed, kind)
    em = v.details.msso
    m = em.result
    alpha, beta = m.alpha, m.beta
    assert alpha.shape == beta.shape == v.alpha.shape
    t = _true_factors(case, v)
    cored = t.alpha != 0
    assert cored[np.argmax(np.abs(alpha))] and cored[np.argmax(np.abs(beta))]
    # the mass change has the fill's sign where the map peaks; the cored region holds most
    # of the stiffness change
    assert np.sign(alpha[np.argmax(np.abs(alpha))]) == np.sign(t.alpha[cored][0])
    assert np.sum(beta[cored] ** 2) > 0.6 * np.sum(beta**2)
    # the map's significant region overlaps the true one and agrees with the physical fit
    L = case.profile.length_m
    lo, hi = m.region_m
    assert lo < L - case.core.plug_m and hi > L - case.core.depth_m
    assert m.peak_z > 5 and em.agrees_with_fit
    # the contract's elements stay the fitted core's section ratios
    assert v.altered and "core fit" in v.details.fit.element_source


@pytest.mark.parametrize("seed", [11, 15])
def test_unaltered_map_within_noise(seed):
    case, v = _inspect(seed, "none")
    em = v.details.msso
    m = em.result
    alpha, beta = m.alpha, m.beta
    assert not v.altered and m.region_m is None and em.agrees_with_fit
    assert m.peak_z < 3
    assert np.all(np.abs(alpha) < 3 * m.alpha_std)
    assert np.all(np.abs(beta) < 3 * m.beta_std)
