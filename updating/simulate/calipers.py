"""A caliper survey of a virtual bat: what a lab's calipers read at the re-test.

``read_bat`` reads a true profile, with the rulebook's changes (``LocalChange``: shaving and
grooves turn the diameter down, a flat shortens the readings within its half-angle of its
normal, ``updating.model.calipers.width_loss_m``), at stations and orientations, as a caliper
does:

- **ovality**: a turned bat is oval by a few thousandths, ``a(x) cos 2(theta - theta0(x))``
  with ``a`` in proportion to the diameter (``OVALITY_IN``: 0.002-0.008 in between the
  widest and narrowest reading on the barrel, so a = 0.001-0.004 in) and theta0 drifting
  along the bat by up to +-``OVALITY_DRIFT_DEG``;
- **placement**: the caliper is set within ``POSITION_SD_IN`` (1 sigma) of the station;
- **noise**: ``NOISE_IN`` (1 sigma) on every reading, written to 0.0001 in.

Orientations are measured from the bat's marked grain plane; on a virtual bat that is the
plane the baseline was tapped in (``VirtualBat.theta_deg`` from the radial plane), so a flat
whose normal lies at ``flat_angle_deg`` from the radial plane faces
``flat_angle_deg - theta_deg`` on the caliper's dial -- the same flat, depth and stretch the
modal simulation of the re-test removes (``retest_survey``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.model.calipers import CaliperSurvey, make_survey, width_loss_m
from updating.model.local_change import LocalChange
from updating.model.profile import Profile
from updating.model.units import IN_TO_M

OVALITY_IN = (0.002, 0.008)
"""A turned bat's widest less narrowest reading on the barrel, in."""
OVALITY_DRIFT_DEG = 15.0
"""How far the oval's axis turns along the bat, deg."""
NOISE_IN = 0.002
"""Caliper noise, 1 sigma, in."""
POSITION_SD_IN = 0.02
"""How far from its station the caliper is set, 1 sigma, in."""


@dataclass(frozen=True)
class Ovality:
    """A bat's ovality: ``a(x) cos 2(theta - theta0(x))``.

    Attributes
    ----------
    amplitude_m : float
        a at the largest diameter, m (in proportion to the diameter elsewhere).
    theta0_deg : float
        The oval's long axis at the knob end, deg from the marked plane.
    drift_deg : float
        How far it turns from the knob to the barrel end, deg.
    """

    amplitude_m: float
    theta0_deg: float
    drift_deg: float

    def width_m(self, x_m: np.ndarray, d_m: np.ndarray, length_m: float,
                angle_deg: np.ndarray) -> np.ndarray:
        """Return what the ovality adds to readings at (x, diameter, orientation), m."""
        theta0 = self.theta0_deg + self.drift_deg * np.asarray(x_m) / length_m
        a = self.amplitude_m * np.asarray(d_m) / np.max(d_m)
        return a * np.cos(np.radians(2 * (np.asarray(angle_deg) - theta0)))


def draw_ovality(rng: np.random.Generator) -> Ovality:
    """Draw a turned bat's ovality (module docstring)."""
    return Ovality(0.5 * rng.uniform(*OVALITY_IN) * IN_TO_M, rng.uniform(0.0, 180.0),
                   rng.uniform(-OVALITY_DRIFT_DEG, OVALITY_DRIFT_DEG))


def orientations_deg(n: int) -> np.ndarray:
    """Return ``n`` orientations spread evenly over 180 deg from the mark (4: 0, 45, 90, 135)."""
    if not 1 <= n <= 36:
        raise ValueError(f"a caliper survey reads 1 to 36 orientations, not {n}")
    return np.arange(n) * 180.0 / n


def true_widths_m(profile: Profile, changes: tuple[LocalChange, ...], x_m: np.ndarray,
                  angle_deg: np.ndarray, mark_deg: float = 0.0) -> np.ndarray:
    """Return a changed bat's true widths at (x, orientation) pairs, m (no ovality, noise).

    Shaving and rings turn the diameter down by their ``diameter_loss_m``; a flat shortens
    the readings within its half-angle of its normal (``width_loss_m``), its normal at
    ``flat_angle_deg - mark_deg`` from the marked plane.

    Parameters
    ----------
    profile : Profile
        The true round profile.
    changes : tuple of LocalChange
        The rulebook's changes (added mass changes no width).
    x_m, angle_deg : ndarray
        Where and at which orientation each reading is taken.
    mark_deg : float
        The marked plane's angle from the radial plane, deg.

    Returns
    -------
    ndarray
        The widths, m.
    """
    x = np.asarray(x_m, dtype=float)
    d = profile.diameter_at(np.clip(x, 0.0, profile.length_m))
    for c in changes:
        inside = (x > c.x0_m) & (x < c.x1_m)
        d = d - np.where(inside, c.diameter_loss_m, 0.0)
    for c in changes:
        if c.flat_depth_m > 0:
            inside = (x > c.x0_m) & (x < c.x1_m)
            loss = width_loss_m(d / 2, c.flat_depth_m,
                                np.asarray(angle_deg) + mark_deg - c.flat_angle_deg)
            d = d - np.where(inside, loss, 0.0)
    return d


def read_bat(rng: np.random.Generator, profile: Profile, changes: tuple[LocalChange, ...],
             stations_m: np.ndarray, angles: np.ndarray, ovality: Ovality,
             mark_deg: float = 0.0, noise_in: float = NOISE_IN,
             position_sd_in: float = POSITION_SD_IN) -> CaliperSurvey:
    """Read a bat's diameter at every station and orientation as a caliper does.

    Parameters
    ----------
    rng : Generator
        Placement and noise.
    profile : Profile
        The true round profile.
    changes : tuple of LocalChange
        The rulebook's changes of the bat.
    stations_m : ndarray
        The stations, m from the knob end.
    angles : ndarray
        The orientations read at every station, deg from the marked plane.
    ovality : Ovality
        The bat's ovality.
    mark_deg : float
        The marked plane's angle from the radial plane, deg.
    noise_in, position_sd_in : float
        Caliper noise and placement, 1 sigma, in.

    Returns
    -------
    CaliperSurvey
        The readings, station by station, orientation by orientation (to 0.0001 in).
    """
    n, k = stations_m.size, angles.size
    x_true = stations_m + position_sd_in * IN_TO_M * rng.standard_normal(n)
    xr = np.repeat(np.clip(x_true, 0.0, profile.length_m), k)
    ar = np.tile(angles, n)
    d = true_widths_m(profile, changes, xr, ar, mark_deg)
    d = d + ovality.width_m(xr, profile.diameter_at(xr), profile.length_m, ar)
    d = d + noise_in * IN_TO_M * rng.standard_normal(d.size)
    d = np.round(d / IN_TO_M, 4) * IN_TO_M
    return make_survey(np.repeat(stations_m, k), ar, d, "simulated survey")


def retest_survey(rng: np.random.Generator, bat, n_orientations: int = 4,
                  noise_in: float = NOISE_IN,
                  mark_deg: float | None = None) -> tuple[CaliperSurvey, dict]:
    """Read a virtual bat's re-test with calipers at the registration's stations.

    Parameters
    ----------
    rng : Generator
        The survey's random source (ovality, placement, noise).
    bat : VirtualBat
        The re-test's truth: its true ``profile`` (the registration's stations) and
        ``local_changes``.
    n_orientations : int
        Orientations spread evenly over 180 deg.
    noise_in : float
        Caliper noise, 1 sigma, in.
    mark_deg : float or None
        The marked plane from the radial plane, deg: the plane the baseline was tapped in
        (its ``theta_deg``); None: ``bat.theta_deg``.

    Returns
    -------
    survey : CaliperSurvey
        The readings.
    truth : dict
        JSON-able: orientations, noise, ovality and each flat's normal on the dial.
    """
    ov = draw_ovality(rng)
    angles = orientations_deg(n_orientations)
    mark = float(bat.theta_deg if mark_deg is None else mark_deg)
    x = np.unique(bat.profile.x_m)
    survey = read_bat(rng, bat.profile, tuple(bat.local_changes), x, angles, ov, mark,
                      noise_in)
    flats = [float((c.flat_angle_deg - mark) % 180.0) for c in bat.local_changes
             if c.flat_depth_m > 0]
    truth = {"orientations_deg": angles.tolist(), "noise_in": noise_in,
             "ovality_in": {"amplitude": ov.amplitude_m / IN_TO_M, "theta0_deg": ov.theta0_deg,
                            "drift_deg": ov.drift_deg},
             "flat_normal_deg": flats}
    return survey, truth
