"""Tail probabilities of the F and chi^2 distributions, from ``scipy.special``.

The same functions ``scipy.stats.f.sf`` and ``scipy.stats.chi2.ppf`` evaluate, without
importing ``scipy.stats`` (most of a second of an inspection's start-up).
"""

from __future__ import annotations

from scipy.special import fdtrc, gammaincinv


def f_sf(F: float, dfn: int, dfd: int) -> float:
    """Return P(F_{dfn, dfd} > F), the F distribution's survival function at F >= 0."""
    return float(fdtrc(dfn, dfd, F))


def chi2_ppf(p: float, df: int) -> float:
    """Return the p quantile of chi^2 with df degrees of freedom (NaN for df < 1).

    x with P(chi^2_df <= x) = p: 2 gammaincinv(df / 2, p).
    """
    return float(2 * gammaincinv(df / 2, p)) if df > 0 else float("nan")
