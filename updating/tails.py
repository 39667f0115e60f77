"""Tail probabilities of the F and chi^2 distributions, from ``scipy.special``.

The same functions ``scipy.stats.f.sf`` and ``scipy.stats.chi2.ppf`` evaluate, without
importing ``scipy.stats`` (a quarter to most of a second of a command's start-up). The
inspection's F test and the diagnosis's naming of causes both read them here.
"""

from __future__ import annotations

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
