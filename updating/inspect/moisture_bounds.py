"""H0's moisture, bounded by what the lab recorded instead of by fixed ranges.

H0 (``hypotheses``) lets the wood's moisture move between the tests: uniformly
(``density_pct``, 1 % of mass per point) and in excess near each end
(``knob_end_moisture_pt``, ``barrel_end_moisture_pt``, decaying as exp(-s / l) from the end,
``model.END_DECAY_M``), and the check that a core is beyond drift (``nested``) lets that
drift reach further. ``moisture_bound`` gives each of those ranges, priors and depths from
the two tests' conditions (``RetestConditions``; docs/noise.md, "Moisture readings"):

1. The days between the tests (both ``tested_on``): the end grain's front can have gone at
   most l_max = 2 sqrt(D_L,high t / pi) deep (``wood_moisture.front_decay_m``, D along the
   grain at its highest), so the check beyond drift reaches l_max where that is deeper than
   three times the model's 2 in front (weeks between the tests), never shallower: a bat
   tested just after weeks in a damp locker redistributes its wet end in the days to the
   re-test, a change deeper than those days' front (a worst-case search with the fronts and
   dates drawn apart found a clean bat called altered when the dates narrowed it); the
   section's uniform change is at most the span of the air a bat lives in (``EMC_SPAN_PT``)
   times the share of the barrel's section diffusion reached
   (``wood_moisture.section_share``), and never more than 3 points.
2. Moisture meter readings at both tests, matched by station (within ``STATION_TOL_M``):
   each test's station mean, as the section's mean moisture after the room
   (``wood_moisture.section_from_reading``: the meter reads the shell, which the
   conditioning hours ``conditioned_h`` at the room's EMC, from ``humidity_pct``, moved
   further than the section; without both, an unknown offset common to the test's stations,
   ``SHELL_UNKNOWN_SD_PT``); the differences d_i = u + e_k w_k(x_i) + e_b w_b(x_i)
   (w = exp(-s / l)) fitted by Bayesian least squares: u flat (H0 had no prior on it),
   e ~ N(0, ``PRIOR_END_MOISTURE_PT``) (H0's prior); covariance: the meter's
   ``METER_SD_PT`` per reading (over the station's count), the conditioning's uncertain
   diffusivity and the unknown offsets, each common to a test's stations. The posterior's
   centre and sd give H0's bounds, centre +- ``BOUND_SD`` sd, cut to the physical ones of
   step 1 (H0's prior stays the physical one: ``READINGS_AS_PRIOR``); the check beyond
   drift's ranges are what the readings alone (each end's prior left out) say, +-
   ``BEYOND_SD`` of their sd, cut to the physical ones three times as wide (``measured``):
   readings as uncertain as one a station leave both as they were.

Weights and temperatures are not used here: the weight is already a datum of the fit (with
its own sd, ``hypotheses.WEIGHT_SIGMA_REL``), and an alteration moves it too; the
temperatures bound the stiffness (``hypotheses.NullBounds.physical``).

With nothing recorded the result is exactly the fixed ranges of before (``NOMINAL``):
density +-3 %, each end +-2.5 points with prior sd 1 point, a 2 in front; beyond drift
three times as wide and three times as deep.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

import numpy as np

from updating.inspect.model import END_DECAY_M, MASS_PER_POINT
from updating.inspect.retest_meta import RetestConditions
from updating.model import wood_moisture as wm
from updating.model.profile import Profile
from updating.model.units import IN_TO_M

PRIOR_END_MOISTURE_PT = 1.0
"""Prior sd of the end-grain moisture excess, points (a typical end, twice the middle)."""
END_MAX_PT, DENSITY_MAX_PCT = 2.5, 3.0
"""Physical bounds without readings: end grain up to 2.5 points beyond the middle, the
uniform moisture +-3 points (+-3 % of mass)."""
BEYOND_FACTOR = 3.0
"""Without readings or dates: the check beyond drift widens the ranges and deepens the end
grain's front this many times (the fixed factor of before)."""
METER_SD_PT = 1.0
"""A moisture meter's error, one reading, points (corrected for species and temperature it
reads within about +-1 point)."""
SHELL_UNKNOWN_SD_PT = 1.0
"""Offset of a test's readings from its section's moisture when its room or conditioning is
not recorded (the shell moved towards an unknown room), points, common to its stations."""
STATION_TOL_M = 0.5 * IN_TO_M
"""Readings within this distance are one station."""
BOUND_SD, BEYOND_SD = 3.0, 5.0
"""H0's bounds, in posterior sds about the posterior's centre; the check beyond drift's
ranges, in sds of what the readings alone say about their estimate (a Gaussian meter leaves
the truth outside 5 sd once in 1.7 million)."""
READINGS_AS_PRIOR = 0.0
"""Whether the posterior is H0's prior (1) or H0 keeps its physical prior and the readings
only bound it (0, the default: on the development fleet one reading a station as the prior
made a clean bat inconclusive, as bounds none; docs/noise.md)."""
UNSEEN_PT = 1e3
"""Prior sd, points, of an end's excess in what the readings alone say: no prior."""
EMC_SPAN_PT = float(wm.emc_pct(80.0) - wm.emc_pct(30.0))
"""How far apart the air a bat lives in can put its moisture: EMC at 80 % less at 30 %."""
MIN_DENSITY_PCT = 0.25
"""Narrowest uniform bound the dates give (the meter-free floor of a same-day re-test)."""


@dataclass(frozen=True)
class MoistureParam:
    """One of H0's moisture parameters: bounds, Gaussian prior, and the range beyond drift.

    Attributes
    ----------
    lower, upper : float
        H0's bounds (points; % of mass for the uniform change).
    center, sd : float
        Its prior (sd inf: none).
    beyond_lower, beyond_upper : float
        The range the check beyond drift allows (``nested._core_beyond_drift``).
    """

    lower: float
    upper: float
    center: float
    sd: float
    beyond_lower: float
    beyond_upper: float

    @staticmethod
    def fixed(half: float, sd: float, factor: float = BEYOND_FACTOR) -> MoistureParam:
        """Return +-``half`` about 0 with prior sd ``sd``, beyond drift ``factor`` as wide."""
        return MoistureParam(-half, half, 0.0, sd, -factor * half, factor * half)


@dataclass(frozen=True)
class MoistureBound:
    """H0's moisture as the lab's records bound it (module docstring).

    Attributes
    ----------
    density_pct, knob_end_pt, barrel_end_pt : MoistureParam
        The uniform change (% of mass, 1 % a point) and each end's excess (points at the end
        face).
    end_decay_m, beyond_decay_m : float
        The end grain's front as H0 models it and as the check beyond drift lets it reach, m.
    days : float or None
        Days between the tests, when both dates are known.
    stations : int
        Stations read at both tests.
    """

    density_pct: MoistureParam
    knob_end_pt: MoistureParam
    barrel_end_pt: MoistureParam
    end_decay_m: float = END_DECAY_M
    beyond_decay_m: float = BEYOND_FACTOR * END_DECAY_M
    days: float | None = None
    stations: int = 0

    def by_name(self) -> dict[str, MoistureParam]:
        """Return the parameters under H0's names (``hypotheses.NULL_NAMES``)."""
        return {"density_pct": self.density_pct, "knob_end_moisture_pt": self.knob_end_pt,
                "barrel_end_moisture_pt": self.barrel_end_pt}

    def beyond_ranges(self) -> dict[str, tuple[float, float]]:
        """Return each parameter's range beyond drift, by H0's name."""
        return {n: (p.beyond_lower, p.beyond_upper) for n, p in self.by_name().items()}


NOMINAL = MoistureBound(MoistureParam.fixed(DENSITY_MAX_PCT, np.inf),
                        MoistureParam.fixed(END_MAX_PT, PRIOR_END_MOISTURE_PT),
                        MoistureParam.fixed(END_MAX_PT, PRIOR_END_MOISTURE_PT))
"""Nothing recorded: the fixed ranges of before."""


def days_between(first: str | None, second: str | None) -> float | None:
    """Return the days from one ISO date to another, None unless both are given."""
    if first is None or second is None:
        return None
    return float((dt.date.fromisoformat(second) - dt.date.fromisoformat(first)).days)


def dated(days: float | None, barrel_radius_m: float) -> MoistureBound:
    """Return the bound the days between the tests give (module docstring, step 1).

    Parameters
    ----------
    days : float or None
        Days between the tests (None: unknown, ``NOMINAL``); a re-test dated before its
        registration is taken as unknown.
    barrel_radius_m : float
        The bat's largest radius, m.
    """
    if days is None or days < 0:
        return NOMINAL
    seconds = max(days, 1.0) * wm.SECONDS_PER_DAY  # a same-day re-test: a day's drift
    d_high = wm.D_ACROSS_M2_S[2]
    reach = wm.front_decay_m(d_high * wm.ALONG_GRAIN_RATIO[2], seconds)
    share = wm.section_share(d_high, seconds, barrel_radius_m)
    half = float(np.clip(EMC_SPAN_PT * share, MIN_DENSITY_PCT, DENSITY_MAX_PCT))
    return MoistureBound(MoistureParam.fixed(half, np.inf), NOMINAL.knob_end_pt,
                         NOMINAL.barrel_end_pt, NOMINAL.end_decay_m,
                         max(reach, NOMINAL.beyond_decay_m), days)


@dataclass(frozen=True)
class StationMeans:
    """One test's readings at the matched stations, as the section's moisture.

    Attributes
    ----------
    value : numpy.ndarray
        (k,) the section's mean moisture after the room at each station, points.
    var : numpy.ndarray
        (k,) the meter's variance of each value (``METER_SD_PT`` over the readings).
    common : numpy.ndarray
        (k,) sd of what the test's stations share (its conditioning, its room).
    """

    value: np.ndarray
    var: np.ndarray
    common: np.ndarray


def _station_groups(readings) -> list[tuple[float, np.ndarray]]:
    """Group readings (x_m, mc) into stations within ``STATION_TOL_M``: (x, values)."""
    arr = np.asarray(readings, dtype=float).reshape(-1, 2)
    arr = arr[np.argsort(arr[:, 0], kind="stable")]
    groups: list[list] = []
    for x, mc in arr:
        if groups and x - groups[-1][0][-1] <= STATION_TOL_M:
            groups[-1][0].append(x)
            groups[-1][1].append(mc)
        else:
            groups.append([[x], [mc]])
    return [(float(np.mean(xs)), np.array(v)) for xs, v in groups]


def matched_stations(first, second) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """Return the stations read at both tests: (x_m, first's readings, second's readings)."""
    out = []
    others = _station_groups(second) if second else []
    for x, values in _station_groups(first) if first else []:
        near = [(abs(x2 - x), x2, v2) for x2, v2 in others if abs(x2 - x) <= STATION_TOL_M]
        if near:
            _, x2, v2 = min(near, key=lambda t: t[0])
            out.append((0.5 * (x + x2), values, v2))
    return out


def section_means(cond: RetestConditions, readings: list[np.ndarray],
                  radius_m: np.ndarray) -> StationMeans:
    """Return one test's station means as the section's moisture after the room.

    Parameters
    ----------
    cond : RetestConditions
        The test's conditions (its room's humidity and hours in it).
    readings : list of numpy.ndarray
        The readings at each station.
    radius_m : numpy.ndarray
        (k,) the bat's radius at each station, m.
    """
    mean = np.array([np.mean(r) for r in readings])
    count = np.array([r.size for r in readings], dtype=float)
    if cond.conditioned_h is None or cond.humidity_pct is None:
        unknown = 0.0 if cond.conditioned_h == 0 else SHELL_UNKNOWN_SD_PT
        return StationMeans(mean, METER_SD_PT**2 / count, np.full(mean.size, unknown))
    emc, seconds = wm.emc_pct(cond.humidity_pct), cond.conditioned_h * wm.SECONDS_PER_HOUR
    values, slopes = [], None
    for d in wm.D_ACROSS_M2_S:
        shell = wm.shell_share(d, seconds)
        section = np.array([wm.section_share(d, seconds, r) for r in radius_m])
        values.append(wm.section_from_reading(mean, emc, shell, section))
        if d == wm.D_ACROSS_M2_S[1]:
            slopes = (1.0 - section) / (1.0 - shell)
    low, nominal, high = values
    return StationMeans(nominal, (METER_SD_PT * slopes) ** 2 / count,
                        np.abs(high - low) / 4.0)  # the diffusivity's range as +-2 sd


def end_weights(x_m: np.ndarray, length_m: float, decay_m: float) -> np.ndarray:
    """(k, 3) the model's rows at stations x: [1, exp(-x / l), exp(-(L - x) / l)]."""
    x = np.clip(np.asarray(x_m, dtype=float), 0.0, length_m)
    return np.column_stack([np.ones_like(x), np.exp(-x / decay_m),
                            np.exp(-(length_m - x) / decay_m)])


def posterior(diff: np.ndarray, cov: np.ndarray, rows: np.ndarray,
              prior_sd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the Gaussian posterior (mean, sd) of theta for diff = rows theta + noise.

    Prior theta ~ N(0, diag(prior_sd^2)) (an infinite sd: flat), noise ~ N(0, cov):
    Sigma = (R^T C^-1 R + P^-1)^-1, mu = Sigma R^T C^-1 diff.
    """
    ci = np.linalg.inv(cov)
    sigma = np.linalg.inv(rows.T @ ci @ rows + np.diag(1.0 / np.asarray(prior_sd) ** 2))
    return sigma @ rows.T @ ci @ diff, np.sqrt(np.diag(sigma))


def moisture_bound(registered: RetestConditions | None, retest: RetestConditions | None,
                   profile: Profile) -> MoistureBound:
    """Bound H0's moisture by the two tests' records (module docstring).

    Parameters
    ----------
    registered, retest : RetestConditions or None
        The registration's conditions (meta.json) and the re-test's (retest.json).
    profile : Profile
        The bat's profile (its length, its radius at each station).

    Returns
    -------
    MoistureBound
        ``NOMINAL`` when neither dates nor readings at both tests are given.
    """
    reg, re = registered or RetestConditions(), retest or RetestConditions()
    length = profile.length_m
    base = dated(days_between(reg.tested_on, re.tested_on),
                 0.5 * float(np.max(profile.diameter_m)))
    stations = matched_stations(reg.moisture, re.moisture)
    if not stations:
        return base
    x = np.array([s[0] for s in stations])
    radius = 0.5 * profile.diameter_at(np.clip(x, 0.0, length))
    first = section_means(reg, [s[1] for s in stations], radius)
    second = section_means(re, [s[2] for s in stations], radius)
    cov = np.diag(first.var + second.var) + np.outer(first.common, first.common) \
        + np.outer(second.common, second.common)
    rows = end_weights(x, length, base.end_decay_m)
    diff = second.value - first.value
    mean, sd = posterior(diff, cov, rows,
                         np.array([np.inf, PRIOR_END_MOISTURE_PT, PRIOR_END_MOISTURE_PT]))
    data, data_sd = posterior(diff, cov, rows, np.array([np.inf, UNSEEN_PT, UNSEEN_PT]))
    per_point = 100.0 * MASS_PER_POINT  # % of mass per point
    params = [measured(per_point * mean[0], per_point * sd[0], per_point * data[0],
                       per_point * data_sd[0], base.density_pct)]
    params += [measured(*v, physical) for v, physical in zip(
        zip(mean[1:], sd[1:], data[1:], data_sd[1:], strict=True),
        (base.knob_end_pt, base.barrel_end_pt), strict=True)]
    return MoistureBound(*params, base.end_decay_m, base.beyond_decay_m, base.days,
                         len(stations))


def overlap(a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    """Return the overlap of two ranges, or ``a`` when they do not overlap."""
    lo, hi = max(a[0], b[0]), min(a[1], b[1])
    return (lo, hi) if lo < hi else a


def measured(center: float, sd: float, data: float, data_sd: float,
             physical: MoistureParam) -> MoistureParam:
    """Return one moisture parameter as the readings and physics bound it together.

    Prior: the posterior (``center``, ``sd``, H0's prior included). Bounds: centre +-
    ``BOUND_SD`` sd within the physical bounds. Beyond drift: what the readings alone say
    (``data`` +- ``BEYOND_SD`` ``data_sd``) within the physical range beyond drift. Both
    hold, so each keeps their overlap; where they do not overlap (the readings say the wood
    moved beyond what was taken as physical) the readings' range alone. Readings as
    uncertain as a meter's single reading (+-3.6 points at the barrel end) leave the
    physical ranges as they were.
    """
    lo, hi = overlap((center - BOUND_SD * sd, center + BOUND_SD * sd),
                     (physical.lower, physical.upper))
    b_lo, b_hi = overlap((data - BEYOND_SD * data_sd, data + BEYOND_SD * data_sd),
                         (physical.beyond_lower, physical.beyond_upper))
    c, s = (center, sd) if READINGS_AS_PRIOR else (physical.center, physical.sd)
    return MoistureParam(float(lo), float(hi), float(c), float(s),
                         float(min(b_lo, lo)), float(max(b_hi, hi)))
