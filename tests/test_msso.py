"""MSSO equations: exact algebra on complete data, ranks, weighting, skyline form, solver."""

import numpy as np
import pytest
import scipy.sparse as sp

from updating.model.assembly import assemble, build_model, skyline_mask
from updating.model.mass_properties import mass_properties
from updating.model.material import paper_material
from updating.model.modes import model_modes
from updating.model.profile import paper_profile
from updating.model.sections import Core
from updating.model.units import IN_TO_M
from updating.msso.regularisation import solve_regularised
from updating.msso.skyline import msso_elements, msso_skyline

ALPHA = -(2 / 3) / 2.7**2
BETA = -(1 / 2.7) ** 4
CORE = slice(23, 32)


@pytest.fixture(scope="module")
def bats():
    ref = build_model(paper_profile(), paper_material())
    cork = build_model(paper_profile(), paper_material(),
                       core=Core(IN_TO_M, 10 * IN_TO_M, 1 / 3, 0.0, IN_TO_M))
    return ref, cork, model_modes(cork, 8)


@pytest.mark.parametrize("m", [1, 6])
def test_complete_exact_modes_give_the_exact_cork(bats, m):
    ref, _, modes = bats
    t = modes.elastic()
    r = msso_elements(ref, t.shapes[:, :m], t.omega2[:m], regularisation=None)
    truth_a = np.zeros(33)
    truth_a[CORE] = ALPHA
    truth_b = np.zeros(33)
    truth_b[CORE] = BETA
    np.testing.assert_allclose(r.factors.alpha_trans, truth_a, atol=1e-5)
    np.testing.assert_allclose(r.factors.beta_bend, truth_b, atol=1e-5)
    assert r.rank == 66 and r.residual_after < 1e-8 * r.residual_before


def test_eigen_block_alone_misses_the_scale_and_blocks_are_weighted(bats):
    ref, _, modes = bats
    t = modes.elastic()
    r = msso_elements(ref, t.shapes[:, :3], t.omega2[:3], regularisation=None)
    # K = M = 0 satisfies P K - Q M = 0: one direction short of 2e unknowns
    assert r.block_ranks["eigen"] == 65
    assert r.block_ranks["mass_norm"] == 6 and r.block_ranks["stiffness_norm"] == 6
    assert set(r.weights) == {"eigen", "mass_norm", "stiffness_norm"}
    assert all(w > 0 for w in r.weights.values())


def test_weighed_mass_fixes_the_scale_of_unscaled_shapes(bats):
    ref, cork, modes = bats
    t = modes.elastic()
    shapes = t.shapes[:, :2] * [4.0, -0.3]  # not mass-normalised
    r = msso_elements(ref, shapes, t.omega2[:2], regularisation=None,
                      weights={"mass_norm": 0.0, "stiffness_norm": 0.0},
                      weighed_mass_kg=mass_properties(cork).mass_kg)
    assert r.weights["mass_norm"] == 0.0
    np.testing.assert_allclose(r.factors.alpha_trans[CORE], ALPHA, atol=1e-5)
    np.testing.assert_allclose(r.factors.beta_bend[CORE], BETA, atol=1e-5)


def test_separate_groups_on_euler_bernoulli_drop_the_empty_parts(bats):
    ref, _, modes = bats
    t = modes.elastic()
    r = msso_elements(ref, t.shapes[:, :4], t.omega2[:4], stiffness="separate",
                      mass="separate", regularisation=None)
    assert r.groups == ("bend", "trans")  # no shear, no rotary inertia in the paper's model
    np.testing.assert_allclose(r.factors.beta_bend[CORE], BETA, atol=1e-5)
    assert np.all(r.factors.beta_shear == 0)


def test_skyline_form_stays_in_the_skyline_and_satisfies_the_equations(bats):
    ref, cork, modes = bats
    t = modes.elastic()
    E, w2 = t.shapes[:, :4], t.omega2[:4]
    r = msso_skyline(ref, E, w2)
    K, M = assemble(ref)
    dK, dM = r.dK.toarray(), r.dM.toarray()
    outside = ~skyline_mask(ref)
    assert np.all(dK[outside] == 0) and np.all(dM[outside] == 0)
    np.testing.assert_allclose(dK, dK.T)
    Ki, Mi = K + dK, M + dM
    np.testing.assert_allclose(E.T @ Mi @ E, np.eye(4), atol=1e-4)
    np.testing.assert_allclose(E.T @ Ki @ E / w2, np.eye(4), atol=1e-4)
    s = 1 / np.sqrt(np.diag(M))[:, None]  # dimensionless rows, as in the MSSO block
    res = s * (Ki @ E / w2 - Mi @ E)
    assert np.linalg.norm(res) < 1e-2 * np.linalg.norm(s * (K @ E / w2 - M @ E))
    assert r.residual_after < 1e-6 * r.residual_before
    assert r.rank < r.n_unknowns  # underdetermined: minimum-norm change


def test_gcv_and_lcurve_beat_the_plain_pseudo_inverse_on_an_ill_posed_problem():
    rng = np.random.default_rng(3)
    n = 60
    x = np.linspace(0, 1, n)
    C = np.exp(-((x[:, None] - x[None, :]) ** 2) / 0.01) / n  # Gaussian blur, ill-posed
    y_true = np.sin(2 * np.pi * x)
    d = C @ y_true + 1e-4 * rng.standard_normal(n)
    err = {k: np.linalg.norm(solve_regularised(C, d, k).y - y_true)
           for k in (None, "gcv", "lcurve")}
    assert err["gcv"] < 0.1 * err[None] and err["lcurve"] < 0.1 * err[None]
    assert err["gcv"] < 0.5 * np.linalg.norm(y_true)


def test_bounds_keep_every_factor_above_minus_one():
    C = sp.csr_matrix(np.eye(3))
    sol = solve_regularised(C, np.array([-2.0, 0.5, -0.5]), 0.0, lower=-0.9)
    assert sol.bounded
    np.testing.assert_allclose(sol.y, [-0.9, 0.5, -0.5], atol=1e-6)
