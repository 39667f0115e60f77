"""Each mode's shape noise from the test's own coherence: the measurement, not a hypothesis.

An H1 estimate from ``n_d`` averaged hits with ordinary coherence gamma^2 has the relative
random error (Bendat and Piersol, Random Data, 4th ed., 9.2.3, eq. 9.65 and 9.90)

    var(H1_hat) / |H|^2 = (1 - gamma^2) / (gamma^2 n_d)        (complex: half on each part)

per frequency line. A residue A_r is estimated from the lines around its peak; with a noise
proportional to |H| (what the coherence measures) each line that mode r dominates carries the
same information about the relative residue, weighted by how much of |H| is mode r's: the
normalised power of its single-degree-of-freedom peak,

    L_r(f) = 1 / (1 + ((f - f_r) / (zeta_r f_r))^2),

so that the relative variance of the residue at point j is

    v_jr = 1 / sum_f L_r(f) / v_j(f),   v_j(f) = (1 - gamma_j^2(f)) / (gamma_j^2(f) n_d).

A mass-normalised real shape is psi_j = A_j / sqrt(A_dp) taken on the mode's phase (the real
part: half of the complex variance), so its relative variance is v_jr / 2 + v_dr / 8 (the
driving point's residue d enters with its square root). The mode's level is the median over
the points (``shape_noise_from_coherence``): the ``sigma_r`` of ``updating.inspect`` (the
relative noise of each shape entry), now measured rather than estimated from a fit's residual.

Files without coherence give None: the inspection then keeps its residual-based estimate.
"""

from __future__ import annotations

import numpy as np

COHERENCE_CLIP = (1e-3, 1.0 - 1e-9)
"""Coherence values used, clipped: gamma^2 = 1 would state a noiseless line."""
UNKNOWN_AVERAGES = 1
"""Averages taken when the file does not say how many hits were averaged: one hit's noise,
the largest the coherence allows (a noise stated too large only lowers the test's power)."""


def line_variance(coherence: np.ndarray, n_averages: int) -> np.ndarray:
    """Return the H1 estimate's relative complex variance per line, (1 - g^2) / (g^2 n_d).

    Parameters
    ----------
    coherence : numpy.ndarray
        Ordinary coherence gamma^2, 0..1, any shape.
    n_averages : int
        Hits averaged into the estimate (n_d >= 1).

    Returns
    -------
    numpy.ndarray
        var(H1_hat) / |H|^2, dimensionless, the shape of ``coherence`` (Bendat and Piersol
        9.90); NaN where the coherence is NaN (a pair not measured).

    Examples
    --------
    >>> round(float(line_variance(np.array(0.8), 4)), 6)
    0.0625
    """
    g2 = np.clip(np.asarray(coherence, dtype=float), *COHERENCE_CLIP)
    return (1.0 - g2) / (g2 * max(int(n_averages), 1))


def shape_noise_from_coherence(
    freq_hz: np.ndarray, coherence: np.ndarray, n_averages: int | None,
    mode_freq_hz: np.ndarray, damping_ratio: np.ndarray, driving: int | None,
) -> np.ndarray | None:
    """Return each mode's relative shape noise from the coherence (module docstring).

    Parameters
    ----------
    freq_hz : numpy.ndarray
        (F,) lines of the fitted band, Hz.
    coherence : numpy.ndarray
        (F, n_points) ordinary coherence of each point's FRF on those lines.
    n_averages : int or None
        Hits averaged per point; None: not recorded (``UNKNOWN_AVERAGES``).
    mode_freq_hz, damping_ratio : numpy.ndarray
        (m,) the fitted modes' frequencies (Hz) and damping ratios as fitted (before any
        window correction: the width of the peaks in these FRFs).
    driving : int or None
        Column of the driving point (its residue scales every shape), None without one.

    Returns
    -------
    numpy.ndarray or None
        (m,) relative standard deviation of a shape entry per mode, or None when there is no
        usable coherence.

    Examples
    --------
    One mode at 100 Hz, 1 % damped, coherence 0.99 on 1 Hz lines (a hit's noise 10 % of the
    signal), 5 averages (4.5 % a line), some 3 lines in the peak: about 2 %.

    >>> f = np.arange(50.0, 150.0)
    >>> s = shape_noise_from_coherence(f, np.full((f.size, 3), 0.99), 5, np.array([100.0]),
    ...                                np.array([0.01]), 0)
    >>> bool(0.01 < s[0] < 0.03)
    True
    """
    if coherence is None:
        return None
    coh = np.asarray(coherence, dtype=float).reshape(np.asarray(freq_hz).size, -1)
    usable = np.isfinite(coh).any(axis=0)
    if not usable.any() or np.asarray(mode_freq_hz).size == 0:
        return None
    v = line_variance(coh, UNKNOWN_AVERAGES if n_averages is None else n_averages)
    f = np.asarray(freq_hz, dtype=float)[:, None]
    fr = np.asarray(mode_freq_hz, dtype=float)[None, :]
    width = np.maximum(np.asarray(damping_ratio, dtype=float)[None, :], 1e-4) * fr
    peak = 1.0 / (1.0 + ((f - fr) / width) ** 2)                        # (F, m)
    info = np.einsum("fm,fj->jm", peak, np.where(np.isfinite(v), 1.0 / v, 0.0))
    var = np.where(info > 0, 1.0 / np.maximum(info, 1e-300), np.nan)   # (n_points, m)
    rel = 0.5 * var[usable]
    if driving is not None and usable[driving]:
        rel = rel + 0.125 * var[driving]
    return np.sqrt(np.nanmedian(rel, axis=0))
