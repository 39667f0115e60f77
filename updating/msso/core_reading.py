"""Reading element factors as a drilled and filled core (docs/method.md).

The changed region is the contiguous run of elements around the most significant one whose
change is significant: z_i = sqrt((beta_i / s_beta_i)^2 + (alpha_i / s_alpha_i)^2) > z_min
and |beta_i| or |alpha_i| > min_change, where s are the resampled (or linearised) standard
deviations, or a robust noise floor (1.4826 x median absolute factor) when none are given.
For an axial core of diameter d in a section of outer diameter D, fill of negligible
stiffness and density ratio r:

    beta = -(d/D)^4  ->  d^4 = mean_i(-beta_i D_i^4)
    alpha = (r - 1)(d/D)^2  ->  r = 1 + mean_i(alpha_i D_i^2) / d^2

over the region (D_i^4, D_i^2: element averages of the profile). Uncertainty: the same
reading applied to each resampled draw.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.model.assembly import BatModel
from updating.msso.update import ElementUpdate


@dataclass(frozen=True)
class CoreReading:
    """The changed region and the core it implies (NaN where not identifiable)."""

    found: bool
    elements: np.ndarray  # element indices (0-based) of the region
    start_m: float
    end_m: float
    beta_mean: float
    alpha_mean: float
    diameter_m: float
    fill_ratio: float
    diameter_std_m: float = np.nan
    fill_ratio_std: float = np.nan
    peak_z: float = 0.0


def _noise(v: np.ndarray, std: np.ndarray | None) -> np.ndarray:
    if std is not None and np.all(std > 0):
        return std
    floor = 1.4826 * np.median(np.abs(v))
    return np.full(v.shape, max(floor, 1e-12))


def changed_region(beta: np.ndarray, alpha: np.ndarray, s_beta=None, s_alpha=None,
                   z_min: float = 3.0, min_change: float = 0.005) -> tuple[np.ndarray, float]:
    """Find the changed region of an element map: the contiguous significant run around its peak.

    An element is significant when z = hypot(beta / s_beta, alpha / s_alpha) > ``z_min``
    and |beta| or |alpha| exceeds ``min_change``.

    Parameters
    ----------
    beta, alpha : (e,) arrays
        Stiffness and mass factors per element.
    s_beta, s_alpha : (e,) arrays, optional
        Their standard deviations; when missing (or not all positive) a robust noise level
        1.4826 median|factor| is used.
    z_min : float
        Significance threshold of z.
    min_change : float
        Smallest factor magnitude counted as a change.

    Returns
    -------
    (int array, float)
        Element indices of the run (empty when nothing is significant) and the peak z.
    """
    zb = beta / _noise(beta, s_beta)
    za = alpha / _noise(alpha, s_alpha)
    z = np.hypot(zb, za)
    big = (np.abs(beta) > min_change) | (np.abs(alpha) > min_change)
    sig = (z > z_min) & big
    if not sig.any():
        return np.array([], dtype=int), float(z.max(initial=0.0))
    peak = int(np.argmax(np.where(sig, z, -np.inf)))
    lo = hi = peak
    while lo > 0 and sig[lo - 1]:
        lo -= 1
    while hi < sig.size - 1 and sig[hi + 1]:
        hi += 1
    return np.arange(lo, hi + 1), float(z[peak])


def core_from_factors(model: BatModel, elements: np.ndarray, beta: np.ndarray,
                      alpha: np.ndarray) -> tuple[float, float]:
    """Read a core's diameter d (m) and fill density ratio r from the factors over ``elements``.

    d^4 = mean(-beta_i <D^4>_i), r = 1 + mean(alpha_i <D^2>_i) / d^2 with D the
    element-averaged outer diameters; (nan, nan) when the mean stiffness change is not a loss.
    """
    D = model.profile.diameter_at(model.samples.x_m)
    D4 = model.element_average(D**4)[elements]
    D2 = model.element_average(D**2)[elements]
    d4 = np.mean(-beta[elements] * D4)
    if d4 <= 0:
        return np.nan, np.nan
    d = d4**0.25
    return float(d), float(1 + np.mean(alpha[elements] * D2) / d**2)


def read_core(model: BatModel, update: ElementUpdate, z_min: float = 3.0,
              min_change: float = 0.005) -> CoreReading:
    """Read the region, core diameter and fill ratio from an ``ElementUpdate``.

    The bending and translational mass factors are read (``changed_region``,
    ``core_from_factors``), with uncertainties from the update's resampled draws.

    Parameters
    ----------
    model : BatModel
        The reference model the update was made on.
    update : ElementUpdate
        The element update.
    z_min, min_change : float
        As ``changed_region`` takes them.

    Returns
    -------
    CoreReading
        Found or not, the elements, region (m), mean factors, diameter (m), fill ratio and
        their standard deviations, peak z.
    """
    beta, alpha = update.factors.beta_bend, update.factors.alpha_trans
    s_b = update.std.beta_bend if update.std is not None else None
    s_a = update.std.alpha_trans if update.std is not None else None
    el, zpk = changed_region(beta, alpha, s_b, s_a, z_min, min_change)
    if el.size == 0:
        return CoreReading(False, el, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan,
                           peak_z=zpk)
    d, r = core_from_factors(model, el, beta, alpha)
    d_std = r_std = np.nan
    if update.draws is not None:
        dr = np.array([core_from_factors(model, el, dw[0], dw[2]) for dw in update.draws])
        d_std, r_std = np.nanstd(dr, axis=0, ddof=1)
    x = model.node_x_m
    return CoreReading(True, el, float(x[el[0]]), float(x[el[-1] + 1]),
                       float(beta[el].mean()), float(alpha[el].mean()), d, r,
                       float(d_std), float(r_std), zpk)
