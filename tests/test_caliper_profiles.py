"""Caliper profiles at several orientations (issue 38): the file, what a caliper reads across a
flat, and the re-test profile's slips refused at the door (units, another bat, knob and
barrel swapped) with one line naming the file."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from batlab.pipeline.files import read_retest_profile
from updating.model.calipers import (
    flat_area_m2,
    read_survey_csv,
    width_loss_m,
    write_survey_csv,
)
from updating.model.profile import read_profile_csv
from updating.model.units import IN_TO_M
from updating.simulate.calipers import Ovality, draw_ovality, orientations_deg, read_bat
from updating.simulate.fleet import pro_profile


def _write(path, rows, header="x_in,diameter_in,angle_deg"):
    path.write_text(header + "\n" + "\n".join(",".join(f"{v:g}" for v in r) for r in rows)
                    + "\n")
    return path


def test_a_registration_profile_read_at_several_orientations_is_their_mean(tmp_path):
    """The ovality a cos 2(theta - theta0) cancels in the mean of 0, 45, 90, 135 deg; a step
    (an orientation read again at one x) stays a step."""
    x = [0.0, 0.5, 10.0, 10.0, 20.0]
    d = [1.5, 1.45, 0.9, 1.7, 2.5]
    rows = []
    for xi, di in zip(x, d, strict=True):
        for a in (0, 45, 90, 135):
            rows.append((xi, di + 0.003 * np.cos(np.radians(2 * (a - 20))), a))
    plain = read_profile_csv(_write(tmp_path / "plain.csv", list(zip(x, d, strict=True)),
                                    "x_in,diameter_in"))
    angled = read_profile_csv(_write(tmp_path / "angled.csv", rows))
    np.testing.assert_allclose(angled.x_m, plain.x_m)
    np.testing.assert_allclose(angled.diameter_m, plain.diameter_m, atol=1e-9)


def test_a_survey_round_trips_and_groups_its_stations(tmp_path):
    rng = np.random.default_rng(1)
    truth = pro_profile(rng)
    survey = read_bat(rng, truth, (), np.unique(truth.x_m), orientations_deg(4),
                      draw_ovality(rng))
    path = tmp_path / "retest_profile.csv"
    write_survey_csv(path, survey)
    back = read_survey_csv(path)
    np.testing.assert_allclose(back.diameter_m, survey.diameter_m, atol=1e-7)
    np.testing.assert_array_equal(back.angle_deg, survey.angle_deg)
    assert len(back.stations()) == np.unique(truth.x_m).size
    assert back.orientations_deg.tolist() == [0.0, 45.0, 90.0, 135.0]
    no_angles = read_survey_csv(_write(tmp_path / "p.csv", [(0, 1.5), (30, 2.5)],
                                       "x_in,diameter_in"))
    assert not no_angles.angles_given and no_angles.orientations_deg.tolist() == [0.0]


@settings(max_examples=40, deadline=None, derandomize=True)
@given(depth_in=st.floats(0.005, 0.2), psi_deg=st.floats(-90.0, 90.0),
       radius_in=st.floats(0.45, 1.3))
def test_the_width_across_a_flat_is_the_flattened_sections_caliper_width(depth_in, psi_deg,
                                                                          radius_in):
    """w(psi) = R (1 - cos(a - |psi|)) against the width of the flattened circle itself:
    the sum of its support distances along the jaws, from a fine polygon of its boundary."""
    R, h = radius_in * IN_TO_M, depth_in * IN_TO_M
    t = np.linspace(0.0, 2 * np.pi, 200001)
    pts = np.column_stack([R * np.cos(t), R * np.sin(t)])
    pts[:, 0] = np.minimum(pts[:, 0], R - h)  # the flat: its normal along +x
    u = np.array([np.cos(np.radians(psi_deg)), np.sin(np.radians(psi_deg))])
    c = np.sqrt(R**2 - (R - h) ** 2)  # the flat's two corners, exactly (the jaws may rest there)
    hull = np.vstack([pts, [[R - h, c], [R - h, -c]]])
    width = (hull @ u).max() - (hull @ u).min()
    assert 2 * R - width == pytest.approx(float(width_loss_m(R, h, psi_deg)), abs=2e-8)
    area = 0.5 * abs(np.sum(pts[:-1, 0] * pts[1:, 1] - pts[1:, 0] * pts[:-1, 1]))
    assert np.pi * R**2 - area == pytest.approx(float(flat_area_m2(R, h)), rel=1e-4)


def test_a_flat_shortens_only_the_readings_within_its_half_angle():
    """0.05 in on a 2.5 in barrel spans +-16 deg about its normal (BAT_PHYSICS)."""
    R, h = 1.25 * IN_TO_M, 0.05 * IN_TO_M
    w = width_loss_m(R, h, np.array([0.0, 16.0, 16.5, 90.0, 180.0]))
    assert w[0] == pytest.approx(h) and w[-1] == pytest.approx(h)
    assert 0 < w[1] < 1e-4 * IN_TO_M and w[2] == 0.0 and w[3] == 0.0


@pytest.fixture
def bat(tmp_path):
    """A registered profile and a clean re-test survey of it, as files."""
    rng = np.random.default_rng(7)
    truth = pro_profile(rng)
    registered = tmp_path / "profile.csv"
    np.savetxt(registered, np.column_stack([truth.x_m, truth.diameter_m]) / IN_TO_M,
               delimiter=",", header="x_in,diameter_in", comments="", fmt="%.4f")
    survey = read_bat(rng, truth, (), np.unique(truth.x_m), orientations_deg(4),
                      Ovality(0.002 * IN_TO_M, 30.0, 0.0))
    path = tmp_path / "retest_profile.csv"
    write_survey_csv(path, survey)
    rows = np.loadtxt(path, delimiter=",", skiprows=1)
    return read_profile_csv(registered), path, rows, truth


def test_a_clean_survey_of_the_same_bat_passes_the_door(bat):
    registered, path, _, _ = bat
    assert read_retest_profile(path, registered).x_m.size > 100


@pytest.mark.parametrize(("slip", "message"), [
    ("diameters_mm", r"diameter \S+ in is outside 0.5-2.75 in: millimetres\?"),
    ("diameters_cm", r"diameter \S+ in is outside 0.5-2.75 in: centimetres\?"),
    ("all_mm", r"millimetres\?"),
    ("stations_cm", r"stations run from 0 to \S+ in, outside the registered bat .*: "
                    r"centimetres\?"),
    ("swapped", r"knob and barrel swapped"),
    ("another_bat", r"% of its stations differ from the registered profile .* another bat"),
    ("longer_bat", r"outside the registered bat .* another bat's profile\?"),
])
def test_a_retest_profile_slip_is_refused_in_one_line(bat, tmp_path, slip, message):
    registered, _, rows, truth = bat
    rows = rows.copy()
    if slip == "diameters_mm":
        rows[:, 1] *= 25.4
    elif slip == "diameters_cm":
        rows[:, 1] *= 2.54
    elif slip == "all_mm":
        rows[:, :2] *= 25.4
    elif slip == "stations_cm":
        rows[:, 0] *= 2.54
    elif slip == "swapped":  # x from the barrel end
        rows[:, 0] = rows[::-1, 0].max() - rows[::-1, 0]
        rows[:, 1:] = rows[::-1, 1:]
    elif slip == "another_bat":
        other = pro_profile(np.random.default_rng(99))
        rows[:, 1] = other.diameter_at(np.clip(rows[:, 0] * IN_TO_M, 0, other.length_m)) / IN_TO_M
        rows[:, 1] = np.where(rows[:, 0] < 14.0, rows[:, 1] + 0.4, rows[:, 1])
    elif slip == "longer_bat":
        rows[:, 0] *= 1.05
    path = _write(tmp_path / "retest_profile.csv", rows)
    with pytest.raises(ValueError, match=message) as err:
        read_retest_profile(path, registered)
    assert str(err.value).startswith(str(path)) and "\n" not in str(err.value)
