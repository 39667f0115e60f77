"""How wood's moisture moves: equilibrium with the air, diffusion, what a meter reads.

The physics both the inspection's moisture bound (``updating.inspect.moisture_bounds``) and
the virtual lab's meter (``updating.simulate.meter``) use (../shared BAT_PHYSICS.md,
"Measuring the confounder"; docs/noise.md, "Moisture readings"):

- equilibrium moisture content (EMC) at a relative humidity, room temperature (about 21 C):
  the Wood Handbook's table (USDA FPL, Wood Handbook 2010, table 4-2, 70 F), linearly
  interpolated (``emc_pct``);
- bound water diffuses about sqrt(D t) deep in a time t (``diffusion_depth_m``): D across
  the grain a few 1e-10 m^2/s (``D_ACROSS_M2_S``: low, nominal, high), along it 10-20 times
  faster (``ALONG_GRAIN_RATIO``);
- a surface held at a new moisture from t = 0 moves a semi-infinite body as
  erfc(z / (2 sqrt(D t))) (Crank, The Mathematics of Diffusion, 1975, eq. 2.45): the end
  grain's excess has the integral 2 sqrt(D_L t / pi) of an exponential of decay length
  ``front_decay_m`` = 2 sqrt(D_L t / pi); a pin meter's shell (``PIN_DEPTH_M``) has moved
  the share ``shell_share`` of the way, the section of a radius R the share
  ``section_share``.

Moisture content in percent of oven-dry mass, lengths in m, times in s.
"""

from __future__ import annotations

import math

import numpy as np

from updating.model.units import IN_TO_M

EMC_TABLE = (  # relative humidity %, EMC % (Wood Handbook 2010, table 4-2, 70 F)
    (0.0, 0.0), (5.0, 1.3), (10.0, 2.5), (15.0, 3.5), (20.0, 4.5), (25.0, 5.4), (30.0, 6.2),
    (35.0, 6.9), (40.0, 7.7), (45.0, 8.5), (50.0, 9.2), (55.0, 10.1), (60.0, 11.0),
    (65.0, 12.0), (70.0, 13.1), (75.0, 14.4), (80.0, 16.0), (85.0, 17.9), (90.0, 20.5),
    (95.0, 24.7), (100.0, 30.0),
)
"""Equilibrium moisture content at room temperature against relative humidity; 100 %: fibre
saturation (about 30 %)."""
D_ACROSS_M2_S = (1.5e-10, 3e-10, 6e-10)
"""Bound-water diffusion coefficient across the grain (low, nominal, high), m^2/s: depths of
0.2-0.4 in in two days and 0.5-1.5 in in four weeks."""
ALONG_GRAIN_RATIO = (10.0, 15.0, 20.0)
"""Along the grain (the end grain) over across it (low, nominal, high)."""
PIN_DEPTH_M = 0.28 * IN_TO_M
"""Depth a pin meter reads to (pins driven 1/4-5/16 in)."""
SECONDS_PER_HOUR, SECONDS_PER_DAY = 3600.0, 86400.0


def emc_pct(humidity_pct) -> np.ndarray | float:
    """Return the equilibrium moisture content at a relative humidity, %.

    Parameters
    ----------
    humidity_pct : float or array_like
        Relative humidity, 0-100 %.

    Returns
    -------
    float or numpy.ndarray
        EMC, % of oven-dry mass (``EMC_TABLE``, linearly interpolated; 50 % gives 9.2).
    """
    rh, emc = np.array(EMC_TABLE).T
    out = np.interp(np.clip(humidity_pct, 0.0, 100.0), rh, emc)
    return float(out) if np.ndim(out) == 0 else out


def diffusion_depth_m(diffusivity_m2_s: float, seconds: float) -> float:
    """Return sqrt(D t), the depth a moisture change reaches by diffusion, m."""
    return math.sqrt(max(diffusivity_m2_s * seconds, 0.0))


def front_decay_m(diffusivity_m2_s: float, seconds: float) -> float:
    """Return the decay length of the exponential with an erfc front's integral, m.

    int_0^inf erfc(s / (2 sqrt(D t))) ds = 2 sqrt(D t / pi): the end grain's excess after
    a time t, as the inspection's exp(-s / l) models it (``updating.inspect.model``).
    """
    return 2.0 * diffusion_depth_m(diffusivity_m2_s, seconds) / math.sqrt(math.pi)


def shell_share(diffusivity_m2_s: float, seconds: float, depth_m: float = PIN_DEPTH_M) -> float:
    """Return the share of a change at the surface that the outer ``depth_m`` has taken up.

    The mean of erfc(z / (2 sqrt(D t))) over 0 <= z <= d: with a = d / (2 sqrt(D t)),
    erfc(a) + (1 - exp(-a^2)) / (a sqrt(pi)); 0 at t = 0, towards 1 as sqrt(D t) >> d.
    """
    depth = diffusion_depth_m(diffusivity_m2_s, seconds)
    if depth <= 0.0:
        return 0.0
    a = depth_m / (2.0 * depth)
    return math.erfc(a) + (1.0 - math.exp(-a * a)) / (a * math.sqrt(math.pi))


def section_share(diffusivity_m2_s: float, seconds: float, radius_m: float) -> float:
    """Return the share of a change at the surface that a round section has taken up.

    The erfc front's integral 2 sqrt(D t / pi) taken as a uniform layer of that depth
    inside a circle of radius R: 1 - (1 - min(depth / R, 1))^2 (the thin-layer limit
    4 sqrt(D t / pi) / R is exact), never above ``shell_share`` at the meter's depth.
    """
    layer = front_decay_m(diffusivity_m2_s, seconds)
    share = 1.0 - (1.0 - min(layer / max(radius_m, 1e-9), 1.0)) ** 2
    return min(share, shell_share(diffusivity_m2_s, seconds))


def shell_reading(section_pct, room_emc_pct: float, shell: float, section: float):
    """Return what a meter reads of a section that has spent a conditioning in a room.

    The section held a uniform b before the room; after it the section's mean is
    b + (E - b) A and the meter's shell b + (E - b) S (A ``section_share``, S
    ``shell_share``, E the room's EMC). From the section's mean after the room (what the
    vibration test sees): r = b_after + (E - b) (S - A), b = (b_after - E A) / (1 - A).
    """
    before = (np.asarray(section_pct, dtype=float) - room_emc_pct * section) / (1.0 - section)
    return np.asarray(section_pct) + (room_emc_pct - before) * (shell - section)


def section_from_reading(reading_pct, room_emc_pct: float, shell: float, section: float):
    """Return the section's mean moisture after the room from a meter's reading.

    ``shell_reading`` inverted: b_after = (r (1 - A) - E (S - A)) / (1 - S).
    """
    r = np.asarray(reading_pct, dtype=float)
    return (r * (1.0 - section) - room_emc_pct * (shell - section)) / (1.0 - shell)
