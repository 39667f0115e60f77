"""A wood field's own shear factor (updating/simulate/wood.py): without one every model is
what it was; with one, kGA alone follows it."""

from dataclasses import replace

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.model.material import Material
from updating.model.profile import paper_profile
from updating.model.units import IN_TO_M
from updating.simulate.virtual_bat import VirtualBat
from updating.simulate.wood import (
    billet_field,
    grid_m,
    moisture_factors,
    moisture_field,
    moisture_profile_pct,
    temperature_field,
)

WOOD = Material(1.74e6 * 6894.757, 600.0, 12.0)
POINTS = np.arange(1.0, 33.0, 2.0) * IN_TO_M


def props(bat):
    return bat.truth_model().samples.props


@settings(max_examples=10, deadline=None)
@given(middle=st.floats(-2.0, 2.0), dt=st.floats(-10.0, 10.0), per_c=st.floats(1e-3, 5e-3))
def test_without_a_shear_factor_g_follows_e_bit_for_bit(middle, dt, per_c):
    """The default field and one whose shear factor is its modulus factor give the same
    sections, bit for bit, and those are the sections scaled by the modulus factor."""
    bat = VirtualBat(paper_profile(), WOOD, POINTS)
    L = bat.profile.length_m
    field = moisture_field(L, middle, 1.8, 2.0, 2.5).times(temperature_field(L, dt, per_c))
    field = field.times(billet_field(L, 0.03, -0.02, 0.4))
    assert field.g_factor is None
    explicit = replace(field, g_factor=field.e_factor.copy())
    p0, p1, p2 = props(bat), props(replace(bat, wood=field)), props(replace(bat, wood=explicit))
    for name in ("ei", "kga", "rhoa", "rhoi"):
        assert np.array_equal(getattr(p1, name), getattr(p2, name))
    e, _ = field.at(bat.truth_model().samples.x_m)
    assert np.array_equal(p1.kga, p0.kga * e)


@settings(max_examples=10, deadline=None)
@given(middle=st.floats(0.3, 2.0) | st.floats(-2.0, -0.3), e_pp=st.floats(-0.025, -0.015),
       g_pp=st.floats(-0.04, -0.02), dt=st.floats(-10.0, 10.0), g_pc=st.floats(1e-3, 5e-3))
def test_a_shear_factor_moves_kga_alone(middle, e_pp, g_pp, dt, g_pc):
    """Moisture with G -2..-4 %/point and E -1.5..-2.5 %/point, temperature with its own
    rate on G: EI follows E's factor, kGA G's, the densities the mass's +1 %/point, sample by
    sample; the product of two fields multiplies the shear factors too."""
    bat = VirtualBat(paper_profile(), WOOD, POINTS)
    L = bat.profile.length_m
    x = grid_m(L)
    d = moisture_profile_pct(x, L, middle, 2.0, 1.5, 3.0)
    moist = moisture_factors(x, d, e_pp, g_pp)
    temp = temperature_field(L, dt, 0.002, g_pc)
    field = moist.times(temp)
    p0, p1 = props(bat), props(replace(bat, wood=field))
    xs = bat.truth_model().samples.x_m
    dx = np.interp(xs, x, d)
    np.testing.assert_allclose(p1.ei, p0.ei * (1 + e_pp * dx) * (1 - 0.002 * dt), rtol=1e-12)
    np.testing.assert_allclose(p1.kga, p0.kga * (1 + g_pp * dx) * (1 - g_pc * dt), rtol=1e-12)
    np.testing.assert_allclose(p1.rhoa, p0.rhoa * (1 + 0.01 * dx), rtol=1e-12)
