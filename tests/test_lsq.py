"""The one least-squares driver and covariance (updating.lsq) and the one mode pairing
(updating.correlate.pairing), against closed forms."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.correlate.pairing import pair_modes
from updating.lsq import covariance, solve_bounded


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(8, 40), p=st.integers(1, 4))
def test_linear_problem_gives_the_normal_equations_solution_and_covariance(seed, n, p):
    """For r(x) = A x - b the solution is lstsq's and the covariance s^2 (A^T A)^-1 with
    s^2 = |r|^2 / (n - p) (ordinary least squares)."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, p))
    b = A @ rng.uniform(-1, 1, p) + 0.1 * rng.standard_normal(n)
    sol = solve_bounded(lambda x: A @ x - b, np.zeros(p), np.full(p, -1e3), np.full(p, 1e3),
                        jac=lambda x: A, xtol=1e-14, ftol=1e-14, gtol=1e-14)
    x_ls = np.linalg.lstsq(A, b, rcond=None)[0]
    np.testing.assert_allclose(sol.x, x_ls, atol=1e-8)
    r = A @ x_ls - b
    expected = (r @ r) / (n - p) * np.linalg.inv(A.T @ A)
    np.testing.assert_allclose(covariance(sol.jac, sol.residual), expected, rtol=1e-6,
                               atol=1e-12)
    assert sol.ssr == pytest.approx(float(r @ r), rel=1e-8)


def test_bounds_hold_and_the_start_is_moved_inside():
    """Minimum at 5 outside [0, 2]: the bounded solution is the bound, from a start in the
    interior and from one outside the box."""
    for x0 in (1.0, 7.0):
        sol = solve_bounded(lambda x: x - 5.0, np.array([x0]), np.array([0.0]),
                            np.array([2.0]))
        assert 0.0 <= sol.x[0] <= 2.0
        assert sol.x[0] == pytest.approx(2.0, abs=1e-6)


def test_a_solution_stopped_short_of_its_bound_counts_as_held_within_the_tolerance():
    """Minimum at 5 outside [0, 2], stopped early by a loose tolerance: scipy may leave x a
    little inside; within ``held_within`` of the bound it is marked held, and a minimum
    well inside is never marked."""
    for x0 in (0.5, 1.0, 1.5):
        sol = solve_bounded(lambda x: x - 5.0, np.array([x0]), np.array([0.0]),
                            np.array([2.0]), held_within=0.01, xtol=1e-2, ftol=1e-2,
                            max_nfev=2)
        assert (sol.active[0] == 1) == (2.0 - sol.x[0] <= 0.01)
    inside = solve_bounded(lambda x: x - 1.0, np.array([0.5]), np.array([0.0]),
                           np.array([2.0]), held_within=0.01)
    assert inside.active[0] == 0 and inside.x[0] == pytest.approx(1.0)
    low = solve_bounded(lambda x: x + 3.0, np.array([1.0]), np.array([0.0]), np.array([2.0]),
                        held_within=0.01)
    assert low.active[0] == -1


def test_rank_deficient_jacobian_gives_a_finite_covariance_on_the_observable_part():
    """Two identical columns: only x1 + x2 is observable. The pseudo-inverse gives each the
    half-variance of the sum, and the variance of x1 + x2 is that of one parameter alone."""
    a = np.linspace(1.0, 2.0, 10)
    J = np.column_stack([a, a])
    cov = covariance(J)  # s^2 = 1: residuals in units of their sigma
    assert np.all(np.isfinite(cov))
    var_sum = np.ones(2) @ cov @ np.ones(2)
    assert var_sum == pytest.approx(1.0 / (a @ a), rel=1e-10)
    assert covariance(np.zeros((5, 0))).shape == (0, 0)


def test_covariance_falls_back_when_there_are_no_degrees_of_freedom():
    J = np.eye(2)
    np.testing.assert_allclose(covariance(J, np.array([0.3, 0.4]), s2_default=4.0), 4 * np.eye(2))
    np.testing.assert_allclose(covariance(J, np.array([0.3, 0.4]), dof=1), 0.25 * np.eye(2))


def test_pairing_drops_or_raises_a_mode_without_partner():
    rng = np.random.default_rng(1)
    b = rng.standard_normal((12, 4))
    a = np.column_stack([b[:, 2], -b[:, 0], rng.standard_normal(12)])  # third: no partner
    a[:, 2] -= b @ np.linalg.lstsq(b, a[:, 2], rcond=None)[0]  # orthogonal to all of b
    pairs = pair_modes(a, b, min_mac=0.9)
    np.testing.assert_array_equal(pairs.index_a, [0, 1])
    np.testing.assert_array_equal(pairs.index_b, [2, 0])
    ia, ib, macs = pairs
    assert np.all(macs > 0.999) and pairs.size == 2
    with pytest.raises(ValueError, match="test mode 3 pairs with no model mode"):
        pair_modes(a, b, min_mac=0.9, weak="raise")


def test_pairing_by_frequency_separates_modes_the_shapes_cannot():
    """Two candidates with the same shape: MAC alone cannot choose, the frequency term does;
    a pair further apart in frequency than max_rel_df is dropped."""
    s = np.random.default_rng(2).standard_normal((10, 1))
    b = np.hstack([s, s])
    pairs = pair_modes(s, b, freq_a_hz=np.array([410.0]), freq_b_hz=np.array([200.0, 400.0]),
                       min_mac=0.9, max_rel_df=0.1)
    np.testing.assert_array_equal(pairs.index_b, [1])
    far = pair_modes(s, b, freq_a_hz=np.array([600.0]), freq_b_hz=np.array([200.0, 400.0]),
                     min_mac=0.9, max_rel_df=0.1)
    assert far.size == 0
