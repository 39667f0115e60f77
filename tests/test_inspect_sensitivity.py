"""The change fit's Jacobian from modal sensitivities (``updating.inspect.sensitivity``).

The fit's Jacobian solves the eigen-problem once and differentiates the modes through their
complete expansion (``updating.model.sensitivity``). Checks: the modes' derivatives of a
random spring-mass chain match finite differences of its eigen-solutions; every column of
the change fit's Jacobian (the null's ten parameters, a core's four, each segment family's)
matches central differences of the residual with one eigen-solution per step, on a random
bat at a random state, with and without a weighed mass.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg

from updating.inspect.changes import differences, pair_tests
from updating.inspect.hypotheses import N_NULL, NullBounds, ParamSpace, residual_function
from updating.inspect.kinds import segment_space
from updating.inspect.model import ChangePredictor, baseline_sensor_offset
from updating.inspect.sensitivity import predicted_change
from updating.model.sensitivity import full_modes, mode_derivatives
from updating.model.units import IN_TO_M
from updating.simulate.fleet import case_modes, random_case


def _chain(k: np.ndarray) -> np.ndarray:
    """Stiffness matrix of a fixed-free chain of springs k."""
    return np.diag(k + np.append(k[1:], 0.0)) - np.diag(k[1:], 1) - np.diag(k[1:], -1)


def _aligned_modes(K: np.ndarray, M: np.ndarray, ref: np.ndarray, m: int):
    """Lowest m eigenpairs with vectors signed like ``ref``'s columns."""
    lam, vec = scipy.linalg.eigh(K, M, subset_by_index=[0, m - 1])
    return lam, vec * np.sign(np.sum(vec * ref[:, :m], axis=0))


def test_mode_derivatives_match_finite_differences():
    rng = np.random.default_rng(3)
    n, m = 12, 4
    k, mass = rng.uniform(1e3, 3e3, n), rng.uniform(0.5, 2.0, n)
    dk, dm = rng.uniform(-1.0, 1.0, n) * k, rng.uniform(-1.0, 1.0, n) * mass
    K, M, dK, dM = _chain(k), np.diag(mass), _chain(dk), np.diag(dm)
    modes = full_modes(K, M)
    rows = np.arange(n)
    d = mode_derivatives(modes, dK[None], dM[None], m, rows)
    h = 1e-6
    lp, vp = _aligned_modes(K + h * dK, M + h * dM, modes.vectors, m)
    lm, vm = _aligned_modes(K - h * dK, M - h * dM, modes.vectors, m)
    assert np.allclose(d.d_lambda[:, 0], (lp - lm) / (2 * h), rtol=1e-6)
    assert np.allclose(d.d_shapes[:, :, 0], (vp - vm) / (2 * h), rtol=1e-5, atol=1e-8)


def _fit_problem(seed: int, weighed: bool):
    """A random bat with a hidden core: predictor, measured changes and the core's space."""
    rng = np.random.default_rng(seed)
    case = random_case(rng, "cork")
    base, re = case_modes(case, rng)
    ref = case.reference
    predict = ChangePredictor(case.profile, ref, np.asarray(base.x_m), ref.sensor_x_m,
                              re.freq_hz.size + 6)
    predict = predict.at_sensor(ref.sensor_x_m + baseline_sensor_offset(
        predict, base.freq_hz, base.shapes))
    pairs = pair_tests(predict, base, re, 0.8)
    diff = differences(predict, base, re, pairs, 0.004 if weighed else None)
    space = ParamSpace(case.profile, NullBounds.physical(), 0.0, 0.0)
    return predict, diff, space, rng


def _random_null(space: ParamSpace, rng: np.random.Generator) -> np.ndarray:
    """A state strictly inside the null bounds, with a grip substance on the handle."""
    lo, hi = space.bounds.lower, space.bounds.upper
    x = lo + (hi - lo) * rng.uniform(0.2, 0.8, lo.size)
    x[7] = max(x[7], 3.0)
    return x


def _family_tail(family: str, rng: np.random.Generator) -> np.ndarray:
    """The family's own parameters at a random place (ends off the element nodes)."""
    start, length = rng.uniform(12.13, 20.37), rng.uniform(3.11, 7.23)
    if family == "core":
        return np.array([rng.uniform(0.33, 2.71), length, rng.uniform(0.2, 1.0),
                         rng.uniform(0.5, 2.0)])
    if family == "local_change":
        return np.array([start, length, rng.uniform(-0.2, -0.05), rng.uniform(0.05, 0.2)])
    if family == "added_mass":
        return np.array([start, length, rng.uniform(5.0, 30.0)])
    return np.array([start, length, rng.uniform(0.02, 0.1)])


@pytest.mark.parametrize("weighed", [False, True])
@pytest.mark.parametrize("family", ["null", "core", "local_change", "added_mass",
                                    "diameter_loss"])
def test_fit_jacobian_matches_central_differences(family, weighed):
    predict, diff, space, rng = _fit_problem(11 + weighed, weighed)
    fspace = space if family in ("null", "core") else segment_space(space, family)
    x = _random_null(space, rng)
    if family != "null":
        x = np.concatenate([x, _family_tail(family, rng)])
    fun = residual_function(predict, diff, fspace, 0.01)
    upper = fspace.upper()[:x.size]
    J = fun.jacobian(x, upper)
    h = 1e-5
    J_fd = np.column_stack([(fun(x + h * e) - fun(x - h * e)) / (2 * h)
                            for e in np.eye(x.size)])
    scale = np.maximum(np.linalg.norm(J_fd, axis=0), 1e-9)
    err = np.linalg.norm(J - J_fd, axis=0) / scale
    assert np.all(err < 2e-3), err
    # the plane mix moves no matrix: its column is the model's own, exactly
    assert np.allclose(J[:, 6], J_fd[:, 6], rtol=1e-6, atol=1e-9)
    assert x.size == N_NULL or np.linalg.norm(J[:, N_NULL:]) > 0


@pytest.mark.parametrize("sensor_mass_g", [0.0, 3.0])
@pytest.mark.parametrize("family", ["null", "core", "local_change", "added_mass",
                                    "diameter_loss"])
def test_matrix_steps_equal_assembled_differences(family, sensor_mass_g):
    """``matrix_steps`` forms each step's difference from the terms it changes: it must be
    the difference of the two assembled states, to round-off, for every parameter (a
    negative accelerometer mass held off its limit included: the reference at 0 g and the
    fit's change of mass below it)."""
    predict, diff, space, rng = _fit_problem(21 + int(sensor_mass_g), False)
    ref = replace(predict.reference, sensor_mass_kg=sensor_mass_g * 1e-3)
    predict = ChangePredictor(predict.profile, ref, predict.points_m, predict.sensor_x_m,
                              predict.n_solve)
    fspace = space if family in ("null", "core") else segment_space(space, family)
    x = _random_null(space, rng)
    if family != "null":
        x = np.concatenate([x, _family_tail(family, rng)])
    x[5] = -abs(x[5]) - 1.0  # the accelerometer lighter than the reference's
    params = fspace.params(x)
    base = predict.matrices(params)
    h = 1e-4
    steps = [(fspace.params(x + h * e), h) for e in np.eye(x.size)]
    dK, dM, dv = predict.matrix_steps(params, base, steps)
    for i, (s, hi) in enumerate(steps):
        st = predict.matrices(s)
        # the assembled difference carries round-off of eps |K| / h; the formed one less
        for got, a, b in ((dK[i], st.K, base.K), (dM[i], st.M, base.M),
                          (dv[i], st.sensor_vector(), base.sensor_vector())):
            want = (a - b) / hi
            tol = 1e-11 * max(np.abs(want).max(), np.abs(b).max() / hi)
            assert np.allclose(got, want, rtol=0, atol=tol), (i, np.abs(got - want).max())
    assert np.count_nonzero(np.abs(dK).sum(axis=(1, 2))) >= 2


def test_predictor_caches_give_the_uncached_matrices():
    """The predictor keeps wood systems (a cored one rebuilt over its core alone), segment
    changes and the accelerometer's point vector across states, keyed by what they depend
    on. A run of states that share and do not share them (cores over and away from the
    grip, the accelerometer and an added mass, segments moved) must give, state by
    state, exactly the matrices of a new predictor that has kept nothing."""
    predict, _, space, rng = _fit_problem(31, False)
    fspace = segment_space(space, "added_mass")

    def fresh():
        return ChangePredictor(predict.profile, predict.reference, predict.points_m,
                               predict.sensor_x_m, predict.n_solve)

    kept = fresh()
    states = []
    for _ in range(12):
        x = _random_null(space, rng)
        states.append(space.params(np.concatenate([x, _family_tail("core", rng)])))
        states.append(fspace.params(np.concatenate([x, _family_tail("added_mass", rng)])))
        tail = _family_tail("core", rng)
        tail[0] = rng.uniform(0.05, 0.4)  # a plug of a few tenths: the hole under the sensor
        states.append(space.params(np.concatenate([x, tail])))
        mass = _family_tail("added_mass", rng)
        mass[:2] = predict.profile.length_m / IN_TO_M - rng.uniform(3.0, 6.0), 2.0
        segs = fspace.params(np.concatenate([x, mass])).segments
        states += [replace(states[-1], core=None, segments=segs),  # a mass, then over a core
                   replace(states[-1], segments=segs)]
    for p in states + states[::-1]:
        got, want = kept.matrices(p), fresh().matrices(p)
        for a, b in ((got.K, want.K), (got.M, want.M), (got.n, want.n),
                     (got.dofs, want.dofs)):
            np.testing.assert_array_equal(a, b)
        assert kept.wood_mass_kg(p) == fresh().wood_mass_kg(p)


def test_kept_modes_are_read_only_and_per_accelerometer():
    """A predictor keeps the modes and derivatives of its last states, read-only; a
    predictor with the accelerometer elsewhere (``at_sensor``, which shares the wood
    systems) keeps its own, the same as a new predictor's there."""
    predict, _, space, rng = _fit_problem(41, False)
    p = space.params(np.concatenate([_random_null(space, rng), _family_tail("core", rng)]))
    f, phi = predict(p)
    assert predict(p)[1] is phi
    with pytest.raises(ValueError, match="read-only"):
        phi[0, 0] = 0.0
    steps = [(replace(p, density_scale=p.density_scale + 1e-4), 1e-4)]
    pc = predicted_change(predict, p, steps)
    assert predicted_change(predict, p, steps) is pc
    with pytest.raises(ValueError, match="read-only"):
        pc.d_shapes[0, 0, 0] = 0.0
    x_s = predict.sensor_x_m - 0.3 * IN_TO_M
    moved = predict.at_sensor(x_s)
    new = ChangePredictor(predict.profile, predict.reference, predict.points_m, x_s,
                          predict.n_solve)
    assert not np.array_equal(moved(p)[1], phi)
    np.testing.assert_array_equal(moved(p)[1], new(p)[1])


def test_a_state_is_solved_once_for_its_residual_and_its_jacobian(monkeypatch):
    """The residual at x and then the Jacobian at x (as trust-region reflective asks for them)
    solve the eigen-problem once, for every mode; the residual's frequencies and shapes are
    those of the lowest modes solved alone (the selective driver), to round-off."""
    import updating.inspect.model as model_module
    from updating.model.modes import solve_modes

    predict, diff, space, rng = _fit_problem(31, True)
    x = np.concatenate([_random_null(space, rng), _family_tail("core", rng)])
    params = space.params(x)
    state = predict.matrices(params)
    alone = solve_modes(state.K, state.M, None, predict.n_solve)
    calls = []
    real = model_module.full_modes
    monkeypatch.setattr(model_module, "full_modes",
                        lambda K, M: calls.append(1) or real(K, M))
    fun = residual_function(predict, diff, space, 0.01)
    fun(x)
    fun.jacobian(x, space.upper()[:x.size])
    assert len(calls) == 1
    freq, shapes = predict(params)
    assert np.allclose(freq, alone.freq_hz, rtol=1e-10, atol=1e-9)
    want = predict.observe(state, alone.shapes)
    sign = np.sign(np.sum(shapes * want, axis=0))
    assert np.allclose(shapes * sign, want, rtol=1e-7, atol=1e-9 * np.abs(want).max())
