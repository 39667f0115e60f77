"""A caliper survey: a bat's diameter read station by station at one or more orientations.

``retest_profile.csv`` (docs/contract.md) has the header ``x_in,diameter_in,angle_deg``: a
station about every 0.5 in from the knob end, each read at one or more orientations of the
jaws, ``angle_deg`` degrees from the bat's marked grain plane (the plane the hammer taps
in; 0, 45, 90 and 135 are usual). Orientations are taken modulo 180 deg. A file without
``angle_deg`` is one orientation (angle 0). Rows are grouped into stations by
``profile.orientation_groups`` (the registration's profile.csv may be written the same way).

What a caliper reads on a changed section (``width_loss_m``): a caliper reads the width
between its jaws, the sum of the section's support distances in the jaws' direction and its
opposite. A round section of radius R with a flat of depth h, its normal at angle phi, has
lost the circular segment of half-angle a, ``cos a = 1 - h / R``; read at angle theta, with
``psi = theta - phi`` folded into [-90, 90] deg, the jaw on the flat's side touches the
chord's end (``|psi| < a``) at ``R cos(a - |psi|)`` from the centre, so the width is short by

    w(psi) = R (1 - cos(a - |psi|))   for |psi| < a, else 0,

h at the normal, spanning +-a about it (a 0.05 in flat on a 2.5 in barrel: +-16 deg;
../docs/kinds.md, "The re-test's caliper profile"). A diameter turned down (shaving, a
groove's ring) shortens every orientation by the diameter lost.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ema.io.atomic_write import atomic_write
from updating.model.local_change import flat_section
from updating.model.profile import (
    Profile,
    check_readings,
    make_profile,
    orientation_groups,
    read_caliper_rows,
)
from updating.model.units import IN_TO_M


@dataclass(frozen=True)
class CaliperSurvey:
    """Caliper readings of a bat, SI.

    Attributes
    ----------
    x_m : ndarray
        (n,) the station of each reading from the knob end, m, non-decreasing.
    angle_deg : ndarray
        (n,) the jaws' orientation from the marked grain plane, deg, in [0, 180).
    diameter_m : ndarray
        (n,) the width read, m.
    angles_given : bool
        False when the file had no ``angle_deg`` column (one orientation, unknown).
    """

    x_m: np.ndarray
    angle_deg: np.ndarray
    diameter_m: np.ndarray
    angles_given: bool = True

    def stations(self) -> list[np.ndarray]:
        """Return the row indices of each station (``profile.orientation_groups``)."""
        return orientation_groups(self.x_m / IN_TO_M, self.angle_deg)

    def station_x_m(self) -> np.ndarray:
        """Return each station's position, m."""
        return np.array([self.x_m[g[0]] for g in self.stations()])

    def mean_profile(self, source: str = "caliper survey") -> Profile:
        """Return the profile of the stations' mean readings (ovality cancels in the mean).

        The stations keep the survey's positions (not shifted to start at 0).
        """
        groups = self.stations()
        x = np.array([self.x_m[g[0]] for g in groups])
        d = np.array([self.diameter_m[g].mean() for g in groups])
        profile = make_profile(x, d, source)
        return Profile(x, profile.diameter_m)

    @property
    def orientations_deg(self) -> np.ndarray:
        """Return the distinct orientations read, deg, sorted."""
        return np.unique(np.round(self.angle_deg, 3))


def make_survey(x_m, angle_deg, diameter_m, source: str = "caliper survey",
                angles_given: bool = True) -> CaliperSurvey:
    """Validate readings and return a survey; raise ValueError naming ``source``.

    Parameters
    ----------
    x_m, angle_deg, diameter_m : array_like
        The readings' stations (m), orientations (deg) and widths (m).
    source : str
        The file, for messages.
    angles_given : bool
        Whether the orientations were given.

    Returns
    -------
    CaliperSurvey
        The readings, orientations modulo 180 deg.
    """
    x = np.asarray(x_m, dtype=float).reshape(-1)
    a = np.mod(np.asarray(angle_deg, dtype=float).reshape(-1), 180.0)
    d = np.asarray(diameter_m, dtype=float).reshape(-1)
    check_readings(source, x, d, a, noun="readings")
    survey = CaliperSurvey(x, a, d, angles_given)
    groups = survey.stations()
    xs = np.array([x[g[0]] for g in groups])
    if np.any((np.diff(xs[:-1]) == 0) & (np.diff(xs[1:]) == 0)):
        raise ValueError(f"{source}: an orientation read more than twice at the same x")
    if xs[-1] <= xs[0]:
        raise ValueError(f"{source}: all readings at one station")
    return survey


def read_survey_csv(path: str | Path) -> CaliperSurvey:
    """Read a caliper survey (``x_in,diameter_in[,angle_deg]``, inches, degrees) into SI.

    Values are checked to be numbers here; their plausibility (units, the same bat as the
    registration) is ``plausible.check_survey``'s.

    Parameters
    ----------
    path : str or Path
        retest_profile.csv (or a profile.csv with or without ``angle_deg``).

    Returns
    -------
    CaliperSurvey
        Its readings.
    """
    x_in, d_in, angle = read_caliper_rows(path)
    given = angle is not None
    if angle is None:
        angle = np.zeros_like(x_in)
    return make_survey(x_in * IN_TO_M, angle, d_in * IN_TO_M, str(path), given)


def write_survey_csv(path: str | Path, survey: CaliperSurvey) -> None:
    """Write a survey as ``x_in,diameter_in,angle_deg`` (temporary file, then rename)."""
    lines = ["x_in,diameter_in,angle_deg"] + [
        f"{x / IN_TO_M:.4f},{d / IN_TO_M:.4f},{a:g}"
        for x, d, a in zip(survey.x_m, survey.diameter_m, survey.angle_deg, strict=True)]
    atomic_write(path, lambda tmp: tmp.write_text("\n".join(lines) + "\n"))


def fold_deg(angle_deg):
    """Fold an angle between two caliper directions into [-90, 90) deg."""
    return np.mod(np.asarray(angle_deg, dtype=float) + 90.0, 180.0) - 90.0


def flat_half_angle(radius_m, depth_m):
    """Return a flat's half-angle a (rad), ``cos a = 1 - h / R`` (module docstring)."""
    R = np.asarray(radius_m, dtype=float)
    return np.arccos(np.clip(1.0 - np.asarray(depth_m, dtype=float) / R, -1.0, 1.0))


def width_loss_m(radius_m, depth_m, psi_deg):
    """Return how much shorter a caliper reads across a flat than across the round section.

    ``w = R (1 - cos(a - |psi|))`` for ``|psi| < a``, else 0 (module docstring).

    Parameters
    ----------
    radius_m : array_like
        The round section's radius, m.
    depth_m : array_like
        The flat's depth, m (0 <= h < R).
    psi_deg : array_like
        The jaws' direction from the flat's normal, deg (folded here).

    Returns
    -------
    ndarray
        The width lost, m (broadcast of the three).
    """
    R = np.asarray(radius_m, dtype=float)
    a = flat_half_angle(R, depth_m)
    psi = np.abs(np.radians(fold_deg(psi_deg)))
    return np.where(psi < a, R * (1.0 - np.cos(a - psi)), 0.0)


def flat_area_m2(radius_m, depth_m):
    """Return the circular segment a flat of depth h cuts off a circle of radius R, m^2.

    ``pi R^2`` less what ``local_change.flat_section`` leaves (``R^2 (a - sin a cos a)``).
    """
    R = np.asarray(radius_m, dtype=float)
    return np.pi * R**2 - flat_section(R, float(depth_m))[0]
