"""Tail probabilities: of the F and chi^2 distributions, and as measured on clean re-tests.

``f_sf``, ``chi2_sf``, ``chi2_isf`` and ``chi2_ppf`` are the functions ``scipy.stats.f.sf``,
``scipy.stats.chi2.sf``, ``.isf`` and ``.ppf`` evaluate, from ``scipy.special``, without
importing ``scipy.stats`` (0.3-0.7 s of a command's start-up); the inspection's F test, the
planes' test of a flat and the diagnosis's naming of causes read them here.
``measured_chance`` is the chance a statistic's value has among the
stored values of clean re-tests (a bat model's calibration), ``measured_cut`` the value past
which that chance is below a level, ``pareto_tail`` its extrapolation beyond them
(``fit_pareto``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import chdtrc, chdtri, fdtrc, fdtri, gammaincinv


def f_sf(F: float, dfn: int, dfd: int) -> float:
    """Return P(F_{dfn, dfd} > F), the F distribution's survival function at F >= 0."""
    return float(fdtrc(dfn, dfd, F))


def f_isf(p: float, dfn: int, dfd: int) -> float:
    """Return F with P(F_{dfn, dfd} > F) = p, the survival function's inverse.

    ``fdtri`` (the distribution function's inverse) at 1 - p: exact to round-off for the
    decision's levels (1e-3 and above); not for p below about 1e-12.
    """
    return float(fdtri(dfn, dfd, 1.0 - p))


def chi2_sf(x: float, df: int) -> float:
    """Return P(chi^2_df > x), the chi^2 distribution's survival function (``chdtrc``)."""
    return float(chdtrc(df, x))


def chi2_isf(q: float, df: int) -> float:
    """Return x with P(chi^2_df > x) = q, the survival function's inverse (``chdtri``)."""
    return float(chdtri(df, q))


def chi2_ppf(p: float, df):
    """Return the p quantile of chi^2 with df degrees of freedom (NaN for df < 1).

    x with P(chi^2_df <= x) = p: 2 gammaincinv(df / 2, p). ``df`` an int gives a float, an
    array of them an array.
    """
    d = np.asarray(df, dtype=float)
    x = np.where(d > 0, 2 * gammaincinv(np.maximum(d, 1.0) / 2, p), np.nan)
    return float(x) if x.ndim == 0 else x


@dataclass(frozen=True)
class MeasuredChance:
    """A statistic's chance among n stored clean re-tests.

    Attributes
    ----------
    value : float
        (1 + exceeding) / (n + 1).
    exceeding : int
        Stored clean re-tests whose statistic is at least as large.
    n : int
        Stored clean re-tests (those without a statistic included).
    """

    value: float
    exceeding: int
    n: int


def measured_chance(statistic: float, null) -> MeasuredChance:
    """Return how often a clean re-test's statistic is at least ``statistic``, as measured.

    The Monte Carlo p-value (1 + b) / (n + 1) (Davison & Hinkley 1997, eq. 4.11): b of the n
    stored clean re-tests have a statistic >= ``statistic``. It is a valid p-value when the
    inspected bat's statistic is exchangeable with the stored ones, at least 1 / (n + 1)
    (the smallest chance n re-tests can show). A stored value that is NaN (a clean re-test
    refused, or judged before the test: no statistic) counts in n and never in b.

    Parameters
    ----------
    statistic : float
        The inspected re-test's statistic (finite).
    null : array_like
        The stored clean re-tests' statistics (NaN: none).

    Returns
    -------
    MeasuredChance
        The chance, b and n.

    Raises
    ------
    ValueError
        No stored re-test, or a statistic that is not finite.
    """
    values = np.asarray(null, dtype=float).ravel()
    if values.size == 0:
        raise ValueError("no stored clean re-test to measure the chance on")
    if not np.isfinite(statistic):
        raise ValueError(f"statistic {statistic!r}: no chance of a value that is not finite")
    exceeding = int(np.count_nonzero(values >= statistic))  # NaN >= x is False
    return MeasuredChance((1 + exceeding) / (values.size + 1), exceeding, int(values.size))


def can_measure_below(n: int, level: float) -> bool:
    """Tell whether n stored re-tests can show a measured chance below ``level``.

    The smallest chance they show is 1 / (n + 1) (``measured_chance``); it is below
    ``level`` when level (n + 1) > 1: from n = 1,000 at 1e-3.
    """
    return level * (n + 1) > 1.0


def measured_cut(null, level: float) -> float:
    """Return the value past which a statistic's measured chance is below ``level``.

    ``measured_chance`` gives (1 + b) / (n + 1), b the stored values at least as large, so
    it is below ``level`` exactly when b <= k = ceil(level (n + 1) - 1) - 1: when the
    statistic exceeds the (k + 1)-th largest stored value (NaN never counts). The n stored
    re-tests cannot show a chance below ``level`` when 1 / (n + 1) >= level (k < 0).

    Parameters
    ----------
    null : array_like
        The stored clean re-tests' statistics (NaN: none; counted in n).
    level : float
        The chance to be below, in (0, 1).

    Returns
    -------
    float
        The cut: the measured chance of s is below ``level`` iff s > cut; inf when no value
        can be, -inf when every value is (fewer than k + 1 finite stored values).

    Examples
    --------
    >>> measured_cut(np.arange(3000.0), 1e-3)  # 3 of 3,000: b <= 2 exceeds 2997
    2997.0
    >>> measured_cut(np.arange(999.0), 1e-3)  # 1 / 1,000 is not below 1e-3
    inf
    """
    values = np.asarray(null, dtype=float).ravel()
    if not can_measure_below(values.size, level):
        return float("inf")
    k = int(np.ceil(level * (values.size + 1) - 1.0)) - 1
    finite = np.sort(values[np.isfinite(values)])[::-1]
    return float(finite[k]) if k < finite.size else float("-inf")


TAIL_FRACTION = 0.1
"""The top share of the stored statistics a generalized Pareto tail is fitted to."""
MIN_TAIL = 30
"""Fewest stored statistics above the threshold a tail fit needs."""


def pareto_tail(statistic: float, null, fraction: float = TAIL_FRACTION,
                min_tail: int = MIN_TAIL) -> float | None:
    """Extrapolate P(statistic or more) beyond the stored values: a generalized Pareto tail.

    Peaks over a threshold (Pickands 1975; Coles 2001, ch. 4): the excesses of the finite
    stored values over u, their (1 - ``fraction``) quantile, fitted by a generalized Pareto
    distribution (maximum likelihood, location 0); P(S >= s) = (k / n) GPD.sf(s - u) for
    s > u, k of the n stored values above u. An extrapolation: a model of the tail, not a
    measurement.

    Parameters
    ----------
    statistic : float
        The inspected re-test's statistic.
    null : array_like
        The stored clean re-tests' statistics (NaN: none; counted in n).
    fraction : float
        The share of the finite stored values the tail is fitted to.
    min_tail : int
        The fewest values above the threshold a fit is made with.

    Returns
    -------
    float or None
        The extrapolated chance; None with fewer than ``min_tail`` values in the tail or a
        statistic not above the threshold.
    """
    values = np.asarray(null, dtype=float).ravel()
    finite = values[np.isfinite(values)]
    if finite.size == 0 or not np.isfinite(statistic):
        return None
    u = float(np.quantile(finite, 1.0 - fraction))
    excess = finite[finite > u] - u
    if excess.size < min_tail or statistic <= u:
        return None
    fit = fit_pareto(excess)
    return float(excess.size / values.size * fit.sf(statistic - u))


@dataclass(frozen=True)
class ParetoFit:
    """A generalized Pareto distribution, location 0: P(Y > y) = (1 + xi y / sigma)^(-1/xi).

    Attributes
    ----------
    shape : float
        xi (0: the exponential distribution, P(Y > y) = exp(-y / sigma)).
    scale : float
        sigma, in the excesses' unit.
    loglik : float
        The log-likelihood of the excesses it was fitted to.
    """

    shape: float
    scale: float
    loglik: float

    def sf(self, y: float) -> float:
        """Return P(Y > y): 0 beyond the upper end (xi < 0, y >= -sigma / xi)."""
        if self.shape == 0.0:
            return float(np.exp(-y / self.scale))
        base = 1.0 + self.shape * y / self.scale
        return float(base ** (-1.0 / self.shape)) if base > 0 else 0.0


PARETO_GRID = 400
"""Trial values of theta = xi / sigma on which ``fit_pareto`` profiles the likelihood before
refining the best."""


def fit_pareto(excess) -> ParetoFit:
    """Fit a generalized Pareto distribution (location 0) to excesses by maximum likelihood.

    The likelihood profiled over theta = xi / sigma (Grimshaw 1993, Technometrics 35(2)):
    for a given theta the maximising shape is xi(theta) = mean(ln(1 + theta y)), sigma =
    xi / theta, and the log-likelihood l(theta) = n (-ln(xi / theta) - xi - 1) (at theta = 0
    the exponential's, -n (ln mean(y) + 1)). theta runs over [theta_-1, 1e6 / mean(y)]: xi
    grows with theta, and below xi = -1 the likelihood grows without bound as the endpoint
    sigma / |xi| nears the largest excess (no maximum-likelihood estimate exists there;
    Smith 1985), so theta stops where xi = -1 (``brentq``), or a hair above -1 / max(y). A
    grid in a stretched coordinate, then the best cell refined
    (``scipy.optimize.minimize_scalar``, bounded). The maximum ``scipy.stats.genpareto``'s
    ``fit(y, floc=0)`` seeks where it has one (xi > -1), without importing scipy.stats (0.7 s
    of a command's start).

    Parameters
    ----------
    excess : array_like
        The excesses over the threshold, all > 0.

    Returns
    -------
    ParetoFit
        Shape, scale and the log-likelihood at them.
    """
    from scipy.optimize import brentq, minimize_scalar

    y = np.asarray(excess, dtype=float)
    n, mean, top = y.size, float(np.mean(y)), float(np.max(y))
    lo, hi = -(1.0 - 1e-9) / top, 1e6 / mean
    if np.mean(np.log1p(lo * y)) < -1.0:  # xi = -1 within reach: no theta beyond it
        lo = brentq(lambda th: float(np.mean(np.log1p(th * y))) + 1.0, lo, 0.0, xtol=1e-15,
                    rtol=1e-14)

    def theta_of(t):  # t in [-1, 1] -> theta in [lo, hi], fine near 0 and both ends
        t = np.asarray(t, dtype=float)
        return np.where(t < 0, lo * np.expm1(-t * np.log(2.0)),
                        np.expm1(t * np.log1p(hi * mean)) / mean)

    def loglik(theta):
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        xi = np.mean(np.log1p(theta[:, None] * y[None, :]), axis=1)
        flat = np.abs(theta) * mean < 1e-12
        safe_theta = np.where(flat, 1.0, theta)
        safe_xi = np.where(flat, 1.0, xi)
        out = n * (-np.log(safe_xi / safe_theta) - safe_xi - 1.0)
        return np.where(flat, -n * (np.log(mean) + 1.0), out), np.where(flat, 0.0, xi)

    grid = np.linspace(-1.0, 1.0, PARETO_GRID + 1)
    ll, _ = loglik(theta_of(grid))
    best = int(np.nanargmax(ll))
    a, b = grid[max(best - 1, 0)], grid[min(best + 1, grid.size - 1)]
    refined = minimize_scalar(lambda t: -float(loglik(theta_of(t))[0][0]), bounds=(a, b),
                              method="bounded", options={"xatol": 1e-12})
    t = float(refined.x) if -refined.fun >= ll[best] else float(grid[best])
    theta = float(theta_of(t))
    ll_best, xi = (float(v[0]) for v in loglik(theta))
    scale = mean if xi == 0.0 else xi / theta
    return ParetoFit(xi, scale, ll_best)
