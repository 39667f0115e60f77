"""The mass line from a roving-hammer test: the fitter's lower residual against the rigid-body
flexibility 1/M + (x - x_c)(x_d - x_c)/I of the simulated bat (accelerometer included).

Hidden effects: bungees from soft to stiff (suspension modes 2-13 Hz, where the Taylor terms
L0 + L1 / w^2 of the suspension stop holding near the band's start), two bending planes whose
first pair is closer than its half-power width (fitted as one pole), 0.5 % noise.
"""

import numpy as np
import pytest

from ema.modal_fit import fit_test
from updating.model.assembly import Attachment, build_model
from updating.model.mass_properties import (
    mass_properties,
    rigid_mass_line,
    solid_mass_properties,
    with_point_mass,
)
from updating.model.material import Material
from updating.model.profile import make_profile
from updating.model.units import IN_TO_M
from updating.simulate.virtual_bat import VirtualBat, simulate_test

X_IN = np.array([0, 0.5, 1.0, 2, 8, 14, 20, 24, 28, 33.5, 34])
D_IN = np.array([1.6, 1.6, 1.0, 0.95, 0.97, 1.2, 1.9, 2.4, 2.55, 2.55, 2.45])
PROFILE = make_profile(X_IN * IN_TO_M, D_IN * IN_TO_M)
POINTS = np.arange(1, 34, 2) * IN_TO_M
WOOD = Material(12.5e9, 640.0, 12.0)


def exact_mass_line(bat: VirtualBat) -> np.ndarray:
    """1/M + (x - x_c)(x_s - x_c)/I_c at the points: the exact mass line of the bat with its
    accelerometer at x_s (rotary inertia counted)."""
    xs = bat.sensor_x_m()
    mp = mass_properties(build_model(PROFILE, WOOD, attachments=(
        Attachment(xs, mass_kg=bat.sensor_mass_kg),)), with_attachments=True)
    return rigid_mass_line(mp, POINTS, xs)


@pytest.mark.parametrize("bungee, two_planes, seed", [
    (50.0, False, 1), (150.0, True, 2), (400.0, False, 3), (800.0, True, 4)])
def test_mass_line_matches_the_rigid_body(bungee, two_planes, seed):
    bat = VirtualBat(PROFILE, WOOD, POINTS, sensor_mass_kg=4e-3, bungee_k_n_per_m=bungee,
                     e_over_g_t=16.0 if two_planes else None, theta_deg=35.0)
    fit = fit_test(simulate_test(bat, seed=seed))
    truth = exact_mass_line(bat)
    row = fit.mass_line[0]
    c1, c0 = np.polyfit(POINTS, row, 1)
    # the driving-point value of the fitted line: 1 g at the barrel end moves it ~0.3 %
    assert (c0 + c1 * POINTS[-1]) / truth[-1] - 1 == pytest.approx(0.0, abs=1.5e-3)
    assert np.abs(row - truth).max() < 0.02 * truth[-1]


def test_a_point_mass_moves_the_mass_line_as_the_model_does():
    """``with_point_mass`` on the bare model's properties is the model with the mass attached,
    and the solid of revolution's properties are the model's but for the sections' rotary
    inertia and the model's smooth profile between stations (0.3 % of the pitch inertia)."""
    xs, m_s = 0.75, 6e-3
    bare = mass_properties(build_model(PROFILE, WOOD))
    both = mass_properties(build_model(PROFILE, WOOD, attachments=(
        Attachment(xs, mass_kg=m_s),)), with_attachments=True)
    added = with_point_mass(bare, m_s, xs)
    for name in ("mass_kg", "cg_m", "i_knob_kg_m2", "i_cg_kg_m2"):
        assert getattr(added, name) == pytest.approx(getattr(both, name), rel=1e-12)
    solid = solid_mass_properties(PROFILE.x_m, PROFILE.diameter_m, bare.mass_kg)
    assert solid.cg_m == pytest.approx(bare.cg_m, rel=2e-4)
    assert solid.i_cg_kg_m2 == pytest.approx(bare.i_cg_kg_m2, rel=5e-3)
    # reciprocity: G(x, x_d) = G(x_d, x)
    assert rigid_mass_line(both, 0.2, xs) == pytest.approx(rigid_mass_line(both, xs, 0.2))
