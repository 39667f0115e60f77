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
from updating.model.mass_properties import mass_properties
from updating.model.material import Material
from updating.model.profile import make_profile
from updating.model.units import IN_TO_M
from updating.simulate.virtual_bat import VirtualBat, simulate_test

X_IN = np.array([0, 0.5, 1.0, 2, 8, 14, 20, 24, 28, 33.5, 34])
D_IN = np.array([1.6, 1.6, 1.0, 0.95, 0.97, 1.2, 1.9, 2.4, 2.55, 2.55, 2.45])
PROFILE = make_profile(X_IN * IN_TO_M, D_IN * IN_TO_M)
POINTS = np.arange(1, 34, 2) * IN_TO_M
WOOD = Material(12.5e9, 640.0, 12.0)


def rigid_flexibility(bat: VirtualBat) -> np.ndarray:
    """1/M + (x - x_c)(x_s - x_c)/I_c at the points: the exact mass line of the bat with its
    accelerometer at x_s (rotary inertia counted)."""
    xs = bat.sensor_x_m()
    mp = mass_properties(build_model(PROFILE, WOOD, attachments=(
        Attachment(xs, mass_kg=bat.sensor_mass_kg),)), with_attachments=True)
    return 1 / mp.mass_kg + (POINTS - mp.cg_m) * (xs - mp.cg_m) / mp.i_cg_kg_m2


@pytest.mark.parametrize("bungee, two_planes, seed", [
    (50.0, False, 1), (150.0, True, 2), (400.0, False, 3), (800.0, True, 4)])
def test_mass_line_matches_the_rigid_body(bungee, two_planes, seed):
    bat = VirtualBat(PROFILE, WOOD, POINTS, sensor_mass_kg=4e-3, bungee_k_n_per_m=bungee,
                     e_over_g_t=16.0 if two_planes else None, theta_deg=35.0)
    fit = fit_test(simulate_test(bat, seed=seed))
    truth = rigid_flexibility(bat)
    row = fit.mass_line[0]
    c1, c0 = np.polyfit(POINTS, row, 1)
    # the driving-point value of the fitted line: 1 g at the barrel end moves it ~0.3 %
    assert (c0 + c1 * POINTS[-1]) / truth[-1] - 1 == pytest.approx(0.0, abs=1.5e-3)
    assert np.abs(row - truth).max() < 0.02 * truth[-1]
