"""Tail probabilities: of the F and chi^2 distributions, and as measured on clean re-tests.

``f_sf`` and ``chi2_ppf`` are the functions ``scipy.stats.f.sf`` and ``scipy.stats.chi2.ppf``
evaluate, from ``scipy.special``, without importing ``scipy.stats`` (a quarter to most of a
second of a command's start-up); the inspection's F test and the diagnosis's naming of causes
both read them here. ``measured_chance`` is the chance a statistic's value has among the
stored values of clean re-tests (a bat model's calibration), ``pareto_tail`` its
extrapolation beyond them (``scipy.stats`` loaded only there).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import fdtrc, gammaincinv


def f_sf(F: float, dfn: int, dfd: int) -> float:
    """Return P(F_{dfn, dfd} > F), the F distribution's survival function at F >= 0."""
    return float(fdtrc(dfn, dfd, F))


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
    from scipy.stats import genpareto  # only here: scipy.stats is slow to import

    shape, _, scale = genpareto.fit(excess, floc=0.0)
    return float(excess.size / values.size * genpareto.sf(statistic - u, shape, 0.0, scale))
