"""What caliper readings do on an unaltered bat: the null of the re-test profile's comparison.

The re-test's survey (``updating.model.calipers.CaliperSurvey``) is compared station by
station with the registered profile g(x) (one diameter a station: its readings' mean when
the registration read several orientations). At station i, orientation theta_k, the drop

    delta_ik = g_i (1 + s) - r_ik

is, on an unaltered bat (../../../docs/kinds.md, "The re-test's caliper profile"):

- caliper noise e_ik, independent, ``sigma_re`` (1 sigma; 0.001-0.002 in; taken as at
  least ``NOISE_FLOOR_IN``);
- the bat's ovality, ``a_i cos 2(theta_k - theta0_i)``: a turned bat is oval by a few
  thousandths. Its two components (cos 2 theta, sin 2 theta) are free at every station: the
  drops are projected off them, so no ovality, however it varies along the bat, can read as
  a change. What it adds to a station's mean over orientations (nothing when they are spread
  evenly over 180 deg), and the registration's own reading at an unknown orientation, are a
  common offset of at most ``a`` (``ovality_m``, taken as systematic along the bat);
- the registration's own noise, ``sigma_g`` per station (estimated from the registered
  profile's third differences: a turned profile is smooth, its third differences are noise,
  variance 20 sigma_g^2; at least ``NOISE_FLOOR_IN``);
- the caliper set at another x (``POSITION_SD_IN``): slope times that, common to a station;
- moisture, which swells or shrinks wood by a few tenths of a percent a point: a uniform
  relative scale ``s``, estimated as the median of the stations' mean drop / g, clipped to
  [-``SCALE_MAX``, 0] (a bat that shrank reads smaller; a swollen one, or a grip or a coat
  that raise the readings, may never make a drop elsewhere).

So each station's drops split into channels: the mean over orientations (variance
``sigma_re^2 / K + sigma_g^2 + (slope sigma_x)^2``, plus the common offsets), the residual
after the mean and the ovality are projected off (``K - 3`` components for K >= 4
orientations, variance ``sigma_re^2``, nothing else) and the ovality's (dropped). ``sigma_re``
is estimated from the residual channel's differences between neighbouring stations (pooled,
``trimmed_sigma``: a change along a run of stations cancels in them but at its ends), ``a``
from the re-test's own ovality fits (their median: noise and a change only raise it). A
null whose mean channel scatters more than its variances say (the robust scale of the
standardised first differences along the bat above 1) is widened by that factor: the null
is never narrower than the data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.model.calipers import CaliperSurvey
from updating.model.profile import Profile
from updating.model.units import IN_TO_M

NOISE_FLOOR_IN = 0.002
"""Caliper noise is taken as at least this, 1 sigma: the high end of a caliper's 0.001-0.002
in (docs/contract.md). A survey cannot show less reliably enough (one residual a station at
four orientations: the estimate scatters by 10-15 %), and at the floor the scan's bound
needs no allowance for the estimate's own uncertainty. A noisier caliper shows in the
survey and is estimated, its uncertainty allowed for by Student's t
(``CaliperNull.dof_retest``)."""
REGISTRATION_NOISE_DEFAULT_IN = 0.003
"""The registered profile's noise when its stations are too few or uneven to estimate it."""
TRIM = 0.1
"""Share of the largest squares left out of a noise estimate (a change's ends, an odd
station)."""
TRIMMED_CHI2_1 = 0.623015
"""Mean of the lower 90 % of chi^2_1: P(chi^2_3 < q) / 0.9 with q = 2.7055, the 90 %
point of chi^2_1 (E[X; X < q] = P(chi^2_3 < q) for X ~ chi^2_1)."""
TRIMMED_EFFICIENCY = 0.78
"""Degrees of freedom of the trimmed estimate per square used (measured: 2 / var of the
estimate over 20,000 draws of 60-67 squares)."""
OVALITY_DEFAULT_IN = 0.004
"""Ovality amplitude assumed when the survey cannot show it (fewer than three orientations):
a turned bat is oval by a few thousandths."""
OVALITY_FLOOR_IN = 0.001
"""The ovality amplitude's floor."""
POSITION_SD_IN = 0.03
"""How far from the registration's station the caliper may be set at the re-test (1 sigma)."""
SCALE_MAX = 0.01
"""Largest uniform shrinkage moisture can make (2.5 points at about 0.2-0.3 % a point)."""
STEP_GUARD_IN = 0.1
"""Stations this close to a step of the registered profile are not compared."""


@dataclass(frozen=True)
class Stations:
    """The survey's stations against the registered profile, SI.

    Attributes
    ----------
    x_m : ndarray
        (N,) the compared stations from the knob end, m.
    g_m : ndarray
        (N,) the registered diameter there, m.
    slope : ndarray
        (N,) the registered profile's slope there (dD/dx).
    angles_deg : tuple of ndarray
        Each station's orientations, deg.
    readings_m : tuple of ndarray
        Each station's readings, m, in the order of its orientations.
    excluded_x_m : ndarray
        Stations not compared (at a step of the registered profile), m.
    """

    x_m: np.ndarray
    g_m: np.ndarray
    slope: np.ndarray
    angles_deg: tuple
    readings_m: tuple
    excluded_x_m: np.ndarray

    @property
    def n(self) -> int:
        """Number of compared stations."""
        return int(self.x_m.size)


@dataclass(frozen=True)
class CaliperNull:
    """What noise, ovality, placement and moisture make of the drops (module docstring), SI.

    Attributes
    ----------
    sigma_retest_m : float
        The re-test caliper's noise, 1 sigma, m.
    sigma_registration_m : float
        The registered profile's noise per station, m.
    ovality_m : float
        The ovality amplitude taken for the common offsets, m.
    scale : float
        The uniform relative shrinkage removed (<= 0).
    scale_sd : float
        Its standard uncertainty.
    inflation : float
        The factor the mean channel's variances were widened by (>= 1).
    noise_estimated : bool
        Whether ``sigma_retest_m`` was estimated from the survey (else assumed).
    ovality_estimated : bool
        Whether ``ovality_m`` was estimated from the survey (else assumed).
    dof_retest, dof_registration : float
        Degrees of freedom of the two noise levels: infinite at their floors (or assumed),
        else the estimate's (``trimmed_sigma``); the scan's statistics are read as Student's
        t with them (``calipers.scan.Terms.dof``).
    """

    sigma_retest_m: float
    sigma_registration_m: float
    ovality_m: float
    scale: float
    scale_sd: float
    inflation: float
    noise_estimated: bool
    ovality_estimated: bool
    dof_retest: float = np.inf
    dof_registration: float = np.inf


@dataclass(frozen=True)
class StationBasis:
    """One station's channels: the mean over orientations and the residual's basis.

    Attributes
    ----------
    q : ndarray
        (K, K - 1 - r) orthonormal basis orthogonal to the mean and the ovality.
    ovality : ndarray
        (K, r) orthonormal basis of the ovality's part orthogonal to the mean.
    mean_ovality : float
        |mean_k exp(2 i theta_k)|: how much of the ovality the mean over orientations keeps.
    """

    q: np.ndarray
    ovality: np.ndarray
    mean_ovality: float


def station_basis(angles_deg: np.ndarray) -> StationBasis:
    """Split a station's K orientations into the mean, ovality and residual channels.

    The ovality's columns ``cos 2 theta``, ``sin 2 theta`` less their mean span r <= 2
    directions (none for one orientation); the residual is the orthogonal complement of
    the mean and those.
    """
    t = np.radians(2.0 * np.asarray(angles_deg, dtype=float))
    K = t.size
    ones = np.ones((K, 1)) / np.sqrt(K)
    ov = np.column_stack([np.cos(t), np.sin(t)])
    ov = ov - ov.mean(axis=0)
    u, s, _ = np.linalg.svd(ov, full_matrices=False)
    ovality = u[:, s > 1e-9 * max(K, 1)]
    full, _, _ = np.linalg.svd(np.hstack([ones, ovality]), full_matrices=True)
    q = full[:, 1 + ovality.shape[1]:]
    return StationBasis(q, ovality, float(abs(np.mean(np.exp(1j * t)))))


def steps_m(profile: Profile) -> np.ndarray:
    """Return where the registered profile steps (two rows at one x), m."""
    x = profile.x_m
    return x[1:][np.diff(x) == 0]


def _diameter_side(profile: Profile, x_m: np.ndarray, side: float) -> np.ndarray:
    """Return the registered diameter at x (linear between stations; the barrel side at a step)."""
    return profile.diameter_at(np.clip(x_m + side, profile.x_m[0], profile.x_m[-1]))


def station_table(survey: CaliperSurvey, registered: Profile) -> Stations:
    """Pair the survey's stations with the registered profile.

    Parameters
    ----------
    survey : CaliperSurvey
        The re-test's readings.
    registered : Profile
        The registered profile (x from its knob end).

    Returns
    -------
    Stations
        The compared stations, with the registered diameter and slope at each.
    """
    groups = survey.stations()
    x = np.array([survey.x_m[g[0]] for g in groups])
    steps = steps_m(registered)
    guard = STEP_GUARD_IN * IN_TO_M
    near_step = np.array([bool(steps.size) and np.min(np.abs(steps - xi)) <= guard for xi in x])
    keep = ~near_step
    xk = x[keep]
    dx = 0.1 * IN_TO_M
    slope = (_diameter_side(registered, xk, dx) - _diameter_side(registered, xk, -dx)) / (2 * dx)
    return Stations(xk, registered.diameter_at(xk), slope,
                    tuple(survey.angle_deg[g] for g, k in zip(groups, keep, strict=True) if k),
                    tuple(survey.diameter_m[g] for g, k in zip(groups, keep, strict=True) if k),
                    x[near_step])


def trimmed_sigma(squares: np.ndarray, scale: float = 1.0) -> tuple[float, float]:
    """Estimate sigma from squares of normal variables of variance ``scale`` sigma^2.

    The mean of the lower 90 % (``TRIM``) over its chi^2_1 value ``TRIMMED_CHI2_1``: robust
    to a few large squares (a change's ends), 78 % as efficient as the plain mean.

    Returns
    -------
    sigma : float
        The estimate (NaN without squares).
    dof : float
        Its degrees of freedom, ``TRIMMED_EFFICIENCY`` per square.
    """
    x = np.sort(np.asarray(squares, dtype=float))
    keep = x[:max(int(np.floor((1 - TRIM) * x.size)), 1)] if x.size else x
    if keep.size == 0:
        return float("nan"), 0.0
    return float(np.sqrt(keep.mean() / TRIMMED_CHI2_1 / scale)), TRIMMED_EFFICIENCY * x.size


def registration_noise_m(registered: Profile) -> tuple[float, float]:
    """Estimate the registered profile's noise per station from its third differences.

    On runs of equally spaced stations (within 1 %), ``d3 = g[i+2] - 3 g[i+1] + 3 g[i] -
    g[i-1]`` has variance 20 sigma^2 for independent noise and almost nothing from a smooth
    turned profile (``trimmed_sigma``), floored at ``NOISE_FLOOR_IN``.

    Returns
    -------
    sigma_m : float
        The estimate (``REGISTRATION_NOISE_DEFAULT_IN`` with fewer than 10 differences), m.
    dof : float
        Its degrees of freedom (infinite when floored or assumed).
    """
    x, g = registered.x_m, registered.diameter_m
    h = np.diff(x)
    n = max(x.size - 3, 0)
    h0, h1, h2 = h[:n], h[1:n + 1], h[2:n + 2]
    even = (h0 > 0) & (h1 > 0) & (h2 > 0) & (np.abs(h0 - h1) <= 0.01 * h1) & (
        np.abs(h2 - h1) <= 0.01 * h1)
    d3 = (g[3:] - 3 * g[2:-1] + 3 * g[1:-2] - g[:-3])[even]
    if d3.size < 10:
        return REGISTRATION_NOISE_DEFAULT_IN * IN_TO_M, np.inf
    sigma, dof = trimmed_sigma(d3**2, 20.0)
    if sigma <= NOISE_FLOOR_IN * IN_TO_M:
        return NOISE_FLOOR_IN * IN_TO_M, np.inf
    return sigma, dof


def residuals_and_ovality(st: Stations, bases: list[StationBasis],
                          use: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the residual channel's station-to-station differences and the ovality amplitudes.

    Returns
    -------
    residual_diff_m : ndarray
        Every residual component's difference between neighbouring ``use`` stations read at
        the same orientations, pooled, m (variance 2 sigma_re^2; a change along a run of
        stations cancels in them but at its two ends).
    amplitude_m : ndarray
        The re-test's ovality amplitude at each used station with both components, m.
    """
    res, amp = [], []
    for i in np.flatnonzero(use):
        r, b = st.readings_m[i], bases[i]
        j = i + 1
        if (j < st.n and use[j] and st.angles_deg[j].shape == st.angles_deg[i].shape
                and np.allclose(st.angles_deg[j], st.angles_deg[i])):
            res.append(b.q.T @ (st.readings_m[j] - r))
        if b.ovality.shape[1] == 2:
            t = np.radians(2.0 * st.angles_deg[i])
            design = np.column_stack([np.ones_like(t), np.cos(t), np.sin(t)])
            coef = np.linalg.lstsq(design, r, rcond=None)[0]
            amp.append(np.hypot(coef[1], coef[2]))
    return (np.concatenate(res) if res else np.array([])), np.asarray(amp)


def mean_variance(st: Stations, sigma_re: float, sigma_g: float) -> np.ndarray:
    """Variance of each station's mean drop over its orientations, m^2 (module docstring)."""
    k = np.array([a.size for a in st.angles_deg], dtype=float)
    pos = st.slope * POSITION_SD_IN * IN_TO_M
    return sigma_re**2 / k + sigma_g**2 + pos**2


def mean_drops(st: Stations, scale: float) -> np.ndarray:
    """Each station's mean drop over its orientations, g (1 + s) - mean r, m."""
    return np.array([st.g_m[i] * (1 + scale) - st.readings_m[i].mean() for i in range(st.n)])


def _scale(st: Stations, use: np.ndarray) -> tuple[float, float]:
    """Return the uniform relative change (median of mean drop / g, sign flipped) and its sd."""
    ratio = -mean_drops(st, 0.0)[use] / st.g_m[use]
    if ratio.size < 5:
        return 0.0, 0.0
    med = float(np.median(ratio))
    sd = 1.2533 * 1.4826 * float(np.median(np.abs(ratio - med))) / np.sqrt(ratio.size)
    return float(np.clip(med, -SCALE_MAX, 0.0)), sd


def _inflation(st: Stations, scale: float, var: np.ndarray, use: np.ndarray) -> float:
    """Robust scale of the mean channel's standardised first differences, at least 1."""
    y = mean_drops(st, scale)
    idx = np.flatnonzero(use)
    pairs = idx[:-1][np.diff(idx) == 1]
    if pairs.size < 10:
        return 1.0
    z = (y[pairs + 1] - y[pairs]) / np.sqrt(var[pairs] + var[pairs + 1])
    return max(1.0, 1.4826 * float(np.median(np.abs(z - np.median(z)))))


def estimate_null(st: Stations, registered: Profile, bases: list[StationBasis],
                  use: np.ndarray) -> CaliperNull:
    """Estimate the null's noise, ovality, scale and widening from the stations ``use``.

    Parameters
    ----------
    st : Stations
        The compared stations.
    registered : Profile
        The registered profile (its noise from third differences).
    bases : list of StationBasis
        Each station's channels.
    use : ndarray of bool
        The stations the estimates may use (those where no change was found).

    Returns
    -------
    CaliperNull
        The estimates (module docstring).
    """
    diff, amp = residuals_and_ovality(st, bases, use)
    noise_known = diff.size >= 10
    sigma_re, dof_re = NOISE_FLOOR_IN * IN_TO_M, np.inf
    if noise_known:
        est, dof = trimmed_sigma(diff**2, 2.0)
        if est > sigma_re:
            sigma_re, dof_re = est, dof
    ovality_known = amp.size >= 5
    ovality = OVALITY_DEFAULT_IN * IN_TO_M
    if ovality_known:
        ovality = max(float(np.median(amp)), OVALITY_FLOOR_IN * IN_TO_M)
    sigma_g, dof_g = registration_noise_m(registered)
    scale, scale_sd = _scale(st, use)
    inflation = _inflation(st, scale, mean_variance(st, sigma_re, sigma_g), use)
    return CaliperNull(sigma_re, sigma_g, ovality, scale, scale_sd, inflation, noise_known,
                       ovality_known, dof_re, dof_g)
