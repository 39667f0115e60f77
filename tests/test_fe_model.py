"""FE model of the bat: the paper's numbers, analytic beams, convergence, matrix properties."""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.model.assembly import (
    Attachment,
    add_element_blocks,
    assemble,
    build_model,
    skyline_mask,
    with_core,
    with_cores,
)
from updating.model.element import element_parts, shape_functions
from updating.model.mass_properties import mass_properties
from updating.model.material import Material, paper_material
from updating.model.modes import model_modes, rigid_body_shapes, solve_modes
from updating.model.profile import make_profile, paper_profile
from updating.model.sections import Core
from updating.model.units import IN_TO_M, LB_TO_KG

PAPER_HZ = [141.5, 555.9, 979.0, 1956.2]
WOOD = Material(E_pa=12e9, rho_kg_m3=650.0)


def uniform(length_m=0.8, d_m=0.05):
    return make_profile([0, length_m], [d_m, d_m])


def test_paper_bat_dofs_weight_and_frequencies():
    model = build_model(paper_profile(), paper_material())
    assert model.n_nodes == 34 and model.n_dof == 68
    weight_lb = mass_properties(model).mass_kg / LB_TO_KG
    assert weight_lb == pytest.approx(2.1176, abs=1e-4)
    modes = model_modes(model, n_modes=6)
    assert modes.n_rigid == 2 and np.all(modes.freq_hz[:2] == 0.0)
    np.testing.assert_allclose(modes.freq_hz[2:], PAPER_HZ, rtol=2e-3)


def test_paper_cork_weight_change():
    cork = Core(1.0 * IN_TO_M, 10 * IN_TO_M, 1 / 3, 0.0, 1.0 * IN_TO_M)
    m0 = mass_properties(build_model(paper_profile(), paper_material())).mass_kg
    m1 = mass_properties(build_model(paper_profile(), paper_material(), core=cork)).mass_kg
    assert (m0 - m1) / LB_TO_KG == pytest.approx(0.1022, rel=1e-3)


def test_uniform_free_free_euler_bernoulli_matches_analytic():
    length, d = 0.8, 0.05
    model = build_model(uniform(length, d), WOOD, n_elements=80)
    A, I = np.pi * d**2 / 4, np.pi * d**4 / 64
    beta_l = np.array([4.730041, 7.853205, 10.995608])
    exact = beta_l**2 / (2 * np.pi * length**2) * np.sqrt(WOOD.E_pa * I / (WOOD.rho_kg_m3 * A))
    f = model_modes(model, n_modes=5).elastic().freq_hz
    np.testing.assert_allclose(f, exact, rtol=1e-3)


def timoshenko_ss_hz(n, length, d, mat, k):
    """Simply supported Timoshenko beam, lower root of the characteristic quadratic."""
    A, I = np.pi * d**2 / 4, np.pi * d**4 / 64
    kga, ei, ra, ri = k * mat.G_pa * A, mat.E_pa * I, mat.rho_kg_m3 * A, mat.rho_kg_m3 * I
    q = n * np.pi / length
    a2 = ra * ri
    a1 = -(ra * (ei * q**2 + kga) + ri * kga * q**2)
    a0 = kga * q**2 * (ei * q**2 + kga) - (kga * q) ** 2
    w2 = np.roots([a2, a1, a0]).real.min()
    return np.sqrt(w2) / (2 * np.pi)


def ss_frequencies(model, n):
    K, M = assemble(model)
    free = np.setdiff1d(np.arange(model.n_dof), [0, model.n_dof - 2])
    modes = solve_modes(K[np.ix_(free, free)], M[np.ix_(free, free)], n_modes=n)
    return modes.freq_hz


def test_timoshenko_stocky_beam_converges_to_timoshenko_solution():
    length, d = 0.25, 0.05  # L/D = 5: shear and rotary inertia matter
    mat = Material(12e9, 650.0, e_over_g=14.0, nu=0.3)
    k = 6 * 1.3 / (7 + 6 * 0.3)
    exact = np.array([timoshenko_ss_hz(n, length, d, mat, k) for n in (1, 2, 3)])
    errors = []
    for n_el in (8, 16, 32, 64):
        f = ss_frequencies(build_model(uniform(length, d), mat, beam="timoshenko",
                                       n_elements=n_el), 3)
        errors.append(np.abs(f / exact - 1))
    errors = np.array(errors)
    # constant shear strain per element: second-order convergence of the eigenvalues
    assert np.all(errors[:-1] / errors[1:] > 3.5)
    assert errors[-1].max() < 1e-3
    # Euler-Bernoulli overestimates such a stocky beam badly: the check has teeth
    f_eb = ss_frequencies(build_model(uniform(length, d), mat, n_elements=64), 3)
    assert np.all(f_eb / exact - 1 > 0.05)


def test_mesh_convergence_from_above():
    f = [model_modes(build_model(paper_profile(), paper_material(), n_elements=n), 6)
         .elastic().freq_hz for n in (33, 66, 132, 264)]
    diffs = np.diff(np.array(f), axis=0)
    # consistent mass: upper bounds that decrease (to the eigen-solver's round-off, ~1e-9
    # relative at 264 elements)
    assert np.all(diffs <= 1e-8 * np.array(f)[1:])
    assert np.all(np.abs(diffs[-1]) < np.abs(diffs[0]) / 10)


@pytest.mark.parametrize("beam", ["euler", "timoshenko"])
def test_matrices_symmetric_and_definite_rigid_modes_in_null_space(beam):
    model = build_model(paper_profile(), Material(12e9, 650.0, 14.0), beam=beam)
    K, M = assemble(model)
    np.testing.assert_allclose(K, K.T, atol=1e-9 * np.abs(K).max())
    np.testing.assert_allclose(M, M.T, atol=1e-12 * np.abs(M).max())
    assert np.linalg.eigvalsh(M).min() > 0
    lam_k = np.linalg.eigvalsh(K)
    assert lam_k.min() > -1e-10 * lam_k.max()
    assert np.sum(lam_k < 1e-10 * lam_k.max()) == 2  # exactly two rigid-body modes
    R = rigid_body_shapes(model.node_x_m, M)
    assert np.abs(K @ R).max() < 1e-12 * np.abs(K).max()
    modes = model_modes(model)
    np.testing.assert_allclose(modes.shapes.T @ M @ modes.shapes, np.eye(model.n_dof),
                               atol=1e-8)
    # nothing outside the assembly skyline
    assert not np.any(K[~skyline_mask(model)]) and not np.any(M[~skyline_mask(model)])


def test_element_parts_sum_to_exact_timoshenko_and_are_derivatives():
    L, EI, kGA = 0.03, 2.0e3, 5.0e6
    phi = 12 * EI / (kGA * L**2)
    g, w = np.polynomial.legendre.leggauss(4)
    xi, wt = (g + 1) / 2, w * L / 2
    ones = np.ones(4)

    def parts(ei, kga):
        p = 12 * ei / (kga * L**2)
        return element_parts(np.zeros(4, int), xi, wt, ei * ones, kga * ones, ones, ones,
                             np.array([L]), np.array([p]))

    pr = parts(EI, kGA)
    K = pr.k_bend[0] + pr.k_shear[0]
    c = EI / (L**3 * (1 + phi))
    exact = c * np.array([
        [12, 6 * L, -12, 6 * L],
        [6 * L, (4 + phi) * L**2, -6 * L, (2 - phi) * L**2],
        [-12, -6 * L, 12, -6 * L],
        [6 * L, (2 - phi) * L**2, -6 * L, (4 + phi) * L**2]])
    np.testing.assert_allclose(K, exact, rtol=1e-12, atol=1e-9 * np.abs(exact).max())
    h = 1e-6
    up_e, up_g = parts(EI * (1 + h), kGA), parts(EI, kGA * (1 + h))
    dK_dEI = (up_e.k_bend[0] + up_e.k_shear[0] - K) / h
    dK_dkGA = (up_g.k_bend[0] + up_g.k_shear[0] - K) / h
    np.testing.assert_allclose(dK_dEI, pr.k_bend[0], atol=1e-5 * np.abs(K).max())
    np.testing.assert_allclose(dK_dkGA, pr.k_shear[0], atol=1e-5 * np.abs(K).max())


def test_suspension_and_sensor_mass():
    length, d = 0.8, 0.05
    bare = build_model(uniform(length, d), WOOD, n_elements=40)
    mp = mass_properties(bare)
    k = 200.0
    hung = build_model(uniform(length, d), WOOD, n_elements=40,
                       attachments=(Attachment(0.0, k_n_per_m=k), Attachment(length, k_n_per_m=k)))
    f = model_modes(hung, n_modes=3).freq_hz
    bounce = np.sqrt(2 * k / mp.mass_kg) / (2 * np.pi)
    i_cg = mp.mass_kg * length**2 / 12  # slender rod; the Euler model has no rotary inertia
    pitch = np.sqrt(2 * k * (length / 2) ** 2 / i_cg) / (2 * np.pi)
    np.testing.assert_allclose(f[:2], sorted([bounce, pitch]), rtol=1e-3)
    sensor = build_model(uniform(length, d), WOOD, n_elements=40,
                         attachments=(Attachment(0.73 * length, mass_kg=0.004),))
    K, M = assemble(sensor)
    R = rigid_body_shapes(sensor.node_x_m, assemble(bare)[1])
    one = np.zeros(sensor.n_dof)
    one[0::2] = 1.0
    assert one @ M @ one == pytest.approx(mp.mass_kg + 0.004, rel=1e-12)
    assert model_modes(sensor, 3).freq_hz[2] < model_modes(bare, 3).freq_hz[2]
    assert np.abs(K @ R).max() < 1e-12 * np.abs(K).max()


@settings(max_examples=8, deadline=None)
@given(length=st.floats(0.5, 1.0), d=st.floats(0.02, 0.07), E=st.floats(8e9, 16e9))
def test_uniform_beam_first_mode_any_size(length, d, E):
    mat = Material(E, 600.0)
    f1 = model_modes(build_model(uniform(length, d), mat, n_elements=40), 3).freq_hz[2]
    exact = 4.730041**2 / (2 * np.pi * length**2) * np.sqrt(E * (d**2 / 16) / 600.0)
    assert f1 == pytest.approx(exact, rel=1e-3)


def test_partial_fill_core_is_the_filled_core_plus_an_empty_cavity():
    """A ``Core`` with ``empty_m`` (fill at the bottom of the hole, the rest behind the plug
    empty) against the simulator's independent build (the filled part as the core, the empty
    stretch as a cavity): same matrices' modes; and the mass removed is the analytic
    rho [(1 - r) V_filled + V_empty] of the uniform beam."""
    from updating.simulate.cavities import apply_cavities, cavity_stations_m

    length, D, d = 0.84, 0.06, 1.0 * IN_TO_M
    prof = uniform(length, D)
    plug, hole, empty, r = 1.0 * IN_TO_M, 10.0 * IN_TO_M, 4.0 * IN_TO_M, 0.3
    partial = Core(d, plug + hole, r, 0.0, plug, empty)
    filled = Core(d, plug + hole, r, 0.0, plug + empty)
    cavity = Core(d, plug + empty, 0.0, 0.0, plug)
    stations = cavity_stations_m((filled, cavity), length)
    a = build_model(prof, WOOD, beam="timoshenko", n_elements=60, stations_m=stations,
                    core=partial)
    b = apply_cavities(build_model(prof, WOOD, beam="timoshenko", n_elements=60,
                                   stations_m=stations, core=filled), WOOD, (cavity,))
    fa, fb = (model_modes(m, n_modes=8).freq_hz[2:] for m in (a, b))
    np.testing.assert_allclose(fa, fb, rtol=1e-10)
    m0 = mass_properties(build_model(prof, WOOD, n_elements=60)).mass_kg
    area = np.pi / 4 * d**2
    removed = WOOD.rho_kg_m3 * area * ((1 - r) * (hole - empty) + empty)
    assert m0 - mass_properties(a).mass_kg == pytest.approx(removed, rel=1e-9)
    assert partial.mean_fill_density_ratio == pytest.approx(r * (hole - empty) / hole)
    with pytest.raises(ValueError, match="empty length"):
        build_model(prof, WOOD, core=Core(d, plug + hole, r, 0.0, plug, hole))


@settings(max_examples=25, deadline=None)
@given(beam=st.sampled_from(["euler", "timoshenko"]), depth=st.floats(0.1, 0.55),
       plug=st.floats(0.01, 0.6), empty=st.floats(0.0, 0.8), d_in=st.floats(0.2, 0.75),
       ratio=st.floats(0.0, 2.5), on_nodes=st.booleans(), seed=st.integers(0, 99))
def test_with_core_rebuilds_the_cored_model_bit_for_bit(beam, depth, plug, empty, d_in, ratio,
                                                        on_nodes, seed):
    """``with_core`` recomputes only the elements a core reaches: every sample, shear
    parameter and element part must be the full build's exactly, cores ending on a node
    included, and the bare bat's elements untouched."""
    profile = paper_profile()
    L = profile.length_m
    stations = np.sort(np.random.default_rng(seed).uniform(0.01, L - 0.01, 17))
    bare = build_model(profile, paper_material(), beam=beam, stations_m=stations)
    depth_m = depth * L
    plug_m = plug * depth_m
    if on_nodes:  # the hole's ends on nodes of the mesh
        n = bare.node_x_m
        depth_m, plug_m = L - n[n.size // 2], L - n[5 * n.size // 6]
    core = Core(d_in * IN_TO_M, depth_m, ratio, 0.1, plug_m, empty * (depth_m - plug_m))
    full = build_model(profile, paper_material(), beam=beam, stations_m=stations, core=core)
    fast = with_core(bare, core)
    # among a Jacobian's steps: integrated together with other cores, each is its own
    others = (replace(core, depth_m=0.9 * core.depth_m, empty_m=0.0),
              replace(core, diameter_m=0.5 * core.diameter_m))
    for got, want in zip(with_cores(bare, (*others, core)), (*others, core), strict=True):
        alone = with_core(bare, want)
        np.testing.assert_array_equal(got.phi, alone.phi)
        np.testing.assert_array_equal(got.samples.x_m, alone.samples.x_m)
        for k in ("k_bend", "k_shear", "m_trans", "m_rot"):
            np.testing.assert_array_equal(getattr(got.parts, k), getattr(alone.parts, k))
    assert fast.core == core
    np.testing.assert_array_equal(fast.phi, full.phi)
    for k in ("k_bend", "k_shear", "m_trans", "m_rot"):
        np.testing.assert_array_equal(getattr(fast.parts, k), getattr(full.parts, k))
    for k in ("elem", "xi", "weight_m", "x_m"):
        np.testing.assert_array_equal(getattr(fast.samples, k), getattr(full.samples, k))
    for k in ("ei", "kga", "rhoa", "rhoi"):
        np.testing.assert_array_equal(getattr(fast.samples.props, k),
                                      getattr(full.samples.props, k))
    x0, x1 = core.interval_m(L)
    away = (bare.node_x_m[1:] <= x0) | (bare.node_x_m[:-1] >= x1)
    np.testing.assert_array_equal(fast.parts.m_trans[away], bare.parts.m_trans[away])
    with pytest.raises(ValueError, match="uncored"):
        with_core(full, core)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_el=st.integers(1, 80), k=st.integers(0, 4))
def test_element_blocks_add_as_add_at_bit_for_bit(seed, n_el, k):
    """``add_element_blocks`` places element matrices by two strided views instead of
    ``np.add.at``; into zeros it must give ``np.add.at``'s sums bit for bit, whatever the
    magnitudes and signs (zeros of either sign included), one matrix or a stack of k."""
    rng = np.random.default_rng(seed)
    shape = (k, n_el, 4, 4) if k else (n_el, 4, 4)
    mats = rng.standard_normal(shape) * 10.0 ** rng.integers(-12, 12, shape[:-2] + (1, 1))
    mats[rng.random(shape) < 0.2] = -0.0
    n = 2 * n_el + 2
    d = 2 * np.arange(n_el)[:, None] + np.arange(4)[None, :]
    want = np.zeros(shape[:-3] + (n, n))
    at = (d[:, :, None], d[:, None, :])
    if k:
        at = (np.arange(k)[:, None, None, None], *(a[None] for a in at))
    np.add.at(want, at, mats)
    got = add_element_blocks(np.zeros_like(want), mats)
    assert got.tobytes() == want.tobytes()


def test_element_blocks_refuse_a_matrix_of_another_mesh():
    """The blocks of n elements fill a (2n + 2)-square matrix; any other is refused."""
    with pytest.raises(ValueError, match="3 elements need a \\(8, 8\\) matrix"):
        add_element_blocks(np.zeros((10, 10)), np.zeros((3, 4, 4)))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), g=st.integers(1, 8), shuffled=st.booleans())
def test_element_parts_of_equal_runs_sum_as_add_at(seed, g, shuffled):
    """Samples in runs of g an element (a segment's Gauss points) are summed run by run
    instead of by ``np.add.at``; the parts must be add.at's sums bit for bit, and samples in
    any other order (an element's samples apart) still are."""
    rng = np.random.default_rng(seed)
    n_el = int(rng.integers(1, 40))
    elem = np.repeat(np.sort(rng.choice(n_el, int(rng.integers(1, n_el + 1)), replace=False)), g)
    if shuffled:
        elem = rng.permutation(elem)
    xi, w = rng.random(elem.size), rng.random(elem.size) * 1e-3
    props = [rng.standard_normal(elem.size) * 10.0 ** rng.integers(-6, 6) for _ in range(4)]
    L, phi = rng.random(n_el) + 0.01, rng.random(n_el)
    got = element_parts(elem, xi, w, *props, L, phi)
    sf = shape_functions(xi, L[elem], phi[elem])
    for name, coef, b in (("k_bend", props[0], sf.kappa), ("k_shear", props[1], sf.gamma),
                          ("m_trans", props[2], sf.n_w), ("m_rot", props[3], sf.n_theta)):
        want = np.zeros((n_el, 4, 4))
        np.add.at(want, elem, (w * coef)[:, None, None] * b[:, :, None] * b[:, None, :])
        assert getattr(got, name).tobytes() == want.tobytes(), name
