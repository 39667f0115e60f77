"""A local change of the bat (``updating.inspect.segments``) against physics.

- added mass: exactly its grams on the scale; every frequency falls, by Rayleigh's quotient
  to first order (-1/2 dm phi(x)^2 of a mass-normalised shape) for a small point-like mass;
- a lost diameter on a uniform cylinder: the removed mass is rho pi/4 (D^2 - (D - delta)^2)
  times the length, the bending stiffness falls as (1 - delta/D)^4;
- the covered share of each element is continuous in the segment's ends;
- a generic change equals the element factors of MSSO (K = K_S + sum beta_i k_i).
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.inspect.segments import (
    Segment,
    coverage,
    element_masses_kg,
    segment_mass_kg,
    segment_matrices,
)
from updating.model.assembly import assemble, build_model, displacement_at
from updating.model.material import Material
from updating.model.modes import solve_modes
from updating.model.profile import make_profile
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
