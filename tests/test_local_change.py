"""A local change of the bat (``updating.inspect.segments``) against physics.

- added mass: exactly its grams on the scale; every frequency falls, by Rayleigh's quotient
  to first order (-1/2 dm phi(x)^2 of a mass-normalised shape) for a small point-like mass;
- a lost diameter on a uniform cylinder: the removed mass is rho pi/4 (D^2 - (D - delta)^2)
  times the length, the bending stiffness falls as (1 - delta/D)^4;
- the covered share of each element is continuous in the segment's ends;
- a generic change equals the element factors of MSSO (K = K_S + sum beta_i k_i);
- the segments a Jacobian steps, integrated together, are each one's own integration.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.inspect.segments import (
    GAUSS_POINTS,
    MIN_DIAMETER_SHARE,
    Segment,
    coverage,
    element_masses_kg,
    segment_changes,
    segment_mass_kg,
    segment_matrices,
)
from updating.model.assembly import assemble, build_model, displacement_at
from updating.model.element import element_parts
from updating.model.material import Material, paper_material
from updating.model.modes import solve_modes
from updating.model.profile import make_profile, paper_profile
from updating.model.sections import section_props
from updating.model.units import IN_TO_M

WOOD = Material(E_pa=12e9, rho_kg_m3=650.0, e_over_g=13.0)


def cylinder(length_m=0.86, d_m=0.06, n=43):
    prof = make_profile([0, length_m], [d_m, d_m])
    return build_model(prof, WOOD, beam="timoshenko", n_elements=n)


def modes_with(model, segments):
    K, M = assemble(model)
    d = segment_matrices(model, segments)
    if d is not None:
        K, M = K + d[0], M + d[1]
    return solve_modes(K, M, model.node_x_m, 8)


@given(x0=st.floats(0.0, 0.8), ell=st.floats(0.01, 0.3), grams=st.floats(1.0, 50.0))
@settings(max_examples=25, deadline=None)
def test_added_mass_is_on_the_scale_and_lowers_every_frequency(x0, ell, grams):
    model = cylinder()
    for surface in (False, True):  # the mass spreads over the part of the segment on the bat
        seg = Segment(x0, x0 + ell, added_mass_kg=grams * 1e-3, mass_at_surface=surface)
        assert segment_mass_kg(model, [seg]) == pytest.approx(grams * 1e-3, rel=1e-9)
    f0 = modes_with(model, []).freq_hz[2:]
    f1 = modes_with(model, [seg]).freq_hz[2:]
    assert np.all(f1 < f0)


def test_a_small_added_mass_shifts_frequencies_as_rayleigh_says():
    """df/f = -1/2 mu int phi(x)^2 dx over the segment (mu the mass per metre, phi the
    mass-normalised shape of the unchanged bat), for a mass small enough to be first order."""
    model = cylinder()
    m0 = modes_with(model, [])
    x0, x1 = model.node_x_m[34], model.node_x_m[36]
    grams = 2.0
    m1 = modes_with(model, [Segment(x0, x1, added_mass_kg=grams * 1e-3)])
    xs = np.linspace(x0, x1, 201)
    phi = displacement_at(model, m0.shapes[:, 2:8], xs)  # (201, 6)
    predicted = -0.5 * grams * 1e-3 / (x1 - x0) * np.trapezoid(phi**2, xs, axis=0)
    measured = m1.freq_hz[2:8] / m0.freq_hz[2:8] - 1
    np.testing.assert_allclose(measured, predicted, rtol=0.01, atol=1e-7)


def test_lost_diameter_removes_the_annulus_mass_and_bending_stiffness():
    D, delta = 0.06, 0.002
    model = cylinder(d_m=D)
    x0, x1 = 10 * IN_TO_M, 20 * IN_TO_M
    seg = Segment(x0, x1, diameter_loss_m=delta)
    removed = -segment_mass_kg(model, [seg])
    expected = WOOD.rho_kg_m3 * np.pi / 4 * (D**2 - (D - delta) ** 2) * (x1 - x0)
    assert removed == pytest.approx(expected, rel=1e-6)
    # a segment covering the whole bat: every bending frequency of a slender cylinder scales
    # as sqrt(EI / rhoA) ~ D, so by (1 - delta / D), shear aside
    whole = Segment(0.0, model.node_x_m[-1], diameter_loss_m=delta)
    slender = build_model(make_profile([0, 0.86], [D, D]), WOOD, beam="euler",
                          rotary_inertia=False, n_elements=43)
    f0 = modes_with(slender, []).freq_hz[2:5]
    f1 = modes_with(slender, [whole]).freq_hz[2:5]
    np.testing.assert_allclose(f1 / f0, 1 - delta / D, rtol=1e-6)


@given(x0=st.floats(0.0, 0.5), ell=st.floats(0.05, 0.3), eps=st.floats(-1e-4, 1e-4))
@settings(max_examples=30, deadline=None)
def test_coverage_is_continuous_and_sums_to_the_length(x0, ell, eps):
    nodes = np.linspace(0.0, 0.86, 44)
    w = coverage(nodes, x0, x0 + ell)
    w2 = coverage(nodes, x0 + eps, x0 + ell + eps)
    assert np.all((w >= 0) & (w <= 1))
    assert float(w @ np.diff(nodes)) == pytest.approx(min(ell, 0.86 - x0), abs=1e-12)
    assert np.max(np.abs(w - w2)) <= abs(eps) / np.min(np.diff(nodes)) + 1e-12


def test_a_generic_change_is_msso_element_factors():
    model = cylinder()
    x0, x1 = model.node_x_m[30], model.node_x_m[36]
    seg = Segment(x0, x1, mass_rel=-0.1, bend_rel=-0.02, shear_rel=-0.1)
    inside = np.zeros(model.n_elements)
    inside[30:36] = 1.0
    K, M = assemble(model, beta_bend=-0.02 * inside, beta_shear=-0.1 * inside,
                    alpha_trans=-0.1 * inside, alpha_rot=-0.1 * inside)
    K0, M0 = assemble(model)
    dK, dM = segment_matrices(model, [seg])
    np.testing.assert_allclose(K0 + dK, K, rtol=1e-12, atol=1e-9 * np.abs(K).max())
    np.testing.assert_allclose(M0 + dM, M, rtol=1e-12, atol=1e-12 * np.abs(M).max())
    assert element_masses_kg(model).sum() == pytest.approx(
        WOOD.rho_kg_m3 * np.pi / 4 * 0.06**2 * 0.86, rel=1e-9)


def _one_segment(model, seg):
    """Reference: one segment integrated and placed alone, element by element (the loop
    ``segments_parts`` replaced)."""
    nodes = model.node_x_m
    lo, hi = nodes[:-1], nodes[1:]
    a, b = np.maximum(lo, seg.x0_m), np.minimum(hi, seg.x1_m)
    elem = np.flatnonzero(b > a)
    g, gw = GAUSS_POINTS
    half = 0.5 * (b[elem] - a[elem])
    x = ((a[elem] + half)[:, None] + half[:, None] * g[None, :]).ravel()
    w = (half[:, None] * gw[None, :]).ravel()
    elem = np.repeat(elem, g.size)
    L = np.diff(nodes)
    D = np.asarray(model.profile.diameter_at(x), dtype=float)
    wood = section_props(D, model.material)
    d_ei, d_kga = seg.bend_rel * wood.ei, seg.shear_rel * wood.kga
    d_rhoa, d_rhoi = seg.mass_rel * wood.rhoa, seg.mass_rel * wood.rhoi
    if seg.diameter_loss_m:
        s = np.clip(1.0 - seg.diameter_loss_m / D, MIN_DIAMETER_SHARE, None)
        d_ei = d_ei + wood.ei * (s**4 - 1.0)
        d_kga = d_kga + wood.kga * (s**2 - 1.0)
        d_rhoa = d_rhoa + wood.rhoa * (s**2 - 1.0)
        d_rhoi = d_rhoi + wood.rhoi * (s**4 - 1.0)
    if seg.added_mass_kg and x.size:
        shape = D if seg.mass_at_surface else np.ones_like(D)
        mu = seg.added_mass_kg * shape / float(np.sum(w * shape))
        d_rhoa = d_rhoa + mu
        if seg.mass_at_surface:
            d_rhoi = d_rhoi + mu * D**2 / 8
    if not model.rotary_inertia:
        d_rhoi = np.zeros_like(d_rhoi)
    p = element_parts(elem, (x - nodes[elem]) / L[elem], w, d_ei, d_kga, d_rhoa, d_rhoi, L,
                      model.phi)
    dK, dM = np.zeros((model.n_dof, model.n_dof)), np.zeros((model.n_dof, model.n_dof))
    for e in np.unique(elem):
        d = model.dofs[e]
        dK[np.ix_(d, d)] += p.k_bend[e] + p.k_shear[e]
        dM[np.ix_(d, d)] += p.m_trans[e] + p.m_rot[e]
    return dK, dM, float(np.sum(w * d_rhoa))


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), k=st.integers(1, 9),
       beam=st.sampled_from(["euler", "timoshenko"]))
def test_segments_integrated_together_are_each_alone(seed, k, beam):
    """``segment_changes`` integrates a Jacobian's segments in one pass; each one's dK, dM
    and mass must be its own integration, bit for bit (segments past the ends, over one
    element, of every kind)."""
    rng = np.random.default_rng(seed)
    profile = paper_profile()
    L = profile.length_m
    model = build_model(profile, paper_material(), beam=beam,
                        stations_m=np.sort(rng.uniform(0.01, L - 0.01, 17)))
    segs = []
    for _ in range(k):
        x0 = rng.uniform(-0.05, L)
        segs.append(Segment(x0, x0 + rng.uniform(0.001, 0.3),
                            added_mass_kg=rng.choice([0.0, rng.uniform(0.001, 0.03)]),
                            diameter_loss_m=rng.choice([0.0, rng.uniform(0.0, 0.004)]),
                            mass_rel=rng.choice([0.0, rng.normal(0, 0.1)]),
                            bend_rel=rng.choice([0.0, rng.normal(0, 0.1)]),
                            shear_rel=rng.choice([0.0, rng.normal(0, 0.1)]),
                            mass_at_surface=bool(rng.integers(2))))
    dK, dM, mass = segment_changes(model, segs)
    for i, seg in enumerate(segs):
        want = _one_segment(model, seg)
        np.testing.assert_array_equal(dK[i], want[0])
        np.testing.assert_array_equal(dM[i], want[1])
        assert mass[i] == want[2]
