"""A second look at a pole the global support test would drop: the mode fitted on its own peak.

The global test (``ema.modal_fit``) compares a mode's contribution at resonance with the misfit
of the synthesis of the whole band around it. A real mode can fail it when that misfit is not
the mode's: a band-wide LSFD whose residual terms cannot follow the FRFs near the band's top,
or a few lines ruined by the excitation (a null of the hammer's force spectrum, seen as a dip
of the coherence) next to the peak. So the peak is fitted again on its own:

1. lines within ``WINDOW`` half-power half-widths zeta f (at least ``MIN_HALF_WIDTH`` of f)
   of the pole, with the kept modes inside that window and local residual terms;
2. each line weighted by the inverse variance of the H1 estimate, gamma^2 / (1 - gamma^2)
   (Bendat and Piersol, Random Data, 4th ed., 9.2.3; the median coherence over the FRFs, with
   gamma^2 capped at 0.999), so that lines where the measurement is noise count little;
3. the pole refined on those lines (Nelder-Mead on frequency and damping of the weighted
   squared misfit, the frequency kept within ``MAX_SHIFT`` half-power half-widths of the
   stabilised one; the residues by linear least squares for each trial, ``ema.shapes.lsfd``);
4. the mode's contribution on its highest line (RMS over the FRFs; its resonance as the lines
   sample it) over the weighted RMS misfit of that local fit, that ratio summed in quadrature
   over the lines of its half-power band (the evidence a matched filter sees), and the
   modal phase collinearity of its residues across the points (a mode has one shape: MPC near
   1; a noise pole's residues scatter in phase).

The refined pole only decides; the reported pole stays the stabilised one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from ema.shapes.complexity import mpc
from ema.shapes.lsfd import QUANTITY_POWER, LsfdResult, lsfd

WINDOW = 8.0  # half-power half-widths on each side of the pole
MIN_HALF_WIDTH = 0.005  # of the frequency: the window is at least +-4 % wide
MIN_MPC = 0.9  # a kept mode's residues must be this collinear in phase
MIN_LINES = 3  # a kept peak spans at least this many lines of its half-power band
MAX_SHIFT = 1.0  # the refined frequency within this many half-power half-widths
_OUTSIDE = 1e300  # cost outside those bounds (finite: the simplex compares costs)


@dataclass(frozen=True)
class LocalSupport:
    """The local fit of one pole.

    Attributes
    ----------
    snr : float
        Contribution on its highest line (RMS over the FRFs) over the weighted RMS misfit.
    evidence : float
        The same summed in quadrature over the lines of its half-power band (a matched
        filter: a peak resolved over k lines stands out sqrt(k) times more clearly than one
        line of it; one line at least).
    lines : int
        Lines in the refined pole's half-power band (a peak over fewer than ``MIN_LINES``
        cannot be told from a noise spike by its shape).
    freq_hz : float
        Refined natural frequency, Hz.
    damping_ratio : float
        Refined damping ratio.
    mpc : float
        Modal phase collinearity of the local residues, 0..1.
    shift : float
        |refined - stabilised frequency| in half-power half-widths zeta f of the stabilised
        pole (at least half a line).
    """

    snr: float
    evidence: float
    lines: int
    freq_hz: float
    damping_ratio: float
    mpc: float
    shift: float


def line_weight(coherence: np.ndarray | None) -> np.ndarray | None:
    """Return the inverse-variance weight of each line of an H1 estimate.

    w = g / (1 - g) with g the median over the FRFs of gamma^2, capped at 0.999: the random
    error of |H1| is sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d)) (Bendat and Piersol 9.2.3).

    Parameters
    ----------
    coherence : ndarray or None
        (F, ...) ordinary coherence gamma^2 per line and FRF; None when not measured.

    Returns
    -------
    ndarray or None
        (F,) weights, or None when there is no coherence (all lines count alike).
    """
    if coherence is None:
        return None
    c = np.asarray(coherence, dtype=float).reshape(coherence.shape[0], -1)
    g = np.clip(np.median(c, axis=1), 0.0, 0.999)
    return g / (1.0 - g)


def _pole(freq_hz: float, zeta: float) -> complex:
    wn = 2 * np.pi * freq_hz
    return complex(-zeta * wn, wn * np.sqrt(1 - zeta**2))


def local_support(
    freq_hz: np.ndarray, frf: np.ndarray, quantity: str, mode_hz: float, zeta: float,
    others: np.ndarray, weight: np.ndarray | None,
) -> LocalSupport:
    """Fit one pole on its own peak and measure how well it stands above the misfit there.

    Parameters
    ----------
    freq_hz : ndarray
        (F,) lines, Hz.
    frf : ndarray
        (F, n_frf) complex FRFs of ``quantity``.
    quantity : str
        "receptance", "mobility" or "accelerance".
    mode_hz, zeta : float
        The stabilised pole: natural frequency (Hz) and damping ratio.
    others : ndarray
        (k,) the kept modes' continuous poles, rad/s; those inside the window join the fit.
    weight : ndarray or None
        (F,) line weights (``line_weight``), or None.

    Returns
    -------
    LocalSupport
        The local signal-to-misfit ratio, refined pole, MPC and frequency shift.
    """
    half = max(zeta, MIN_HALF_WIDTH) * mode_hz
    win = (mode_hz - WINDOW * half, mode_hz + WINDOW * half)
    near = others[np.abs(np.abs(others) / (2 * np.pi) - mode_hz) < WINDOW * half]
    sel = (freq_hz >= win[0]) & (freq_hz <= win[1])
    w = np.ones(sel.sum()) if weight is None else weight[sel]
    h = frf[sel]
    z_min = 0.5 * (freq_hz[1] - freq_hz[0]) / mode_hz  # no sharper than the lines resolve
    width = max(zeta, z_min) * mode_hz  # the stabilised pole's half-power half-width, Hz

    def fit(x: np.ndarray) -> LsfdResult:  # x: (shift in half-widths, log damping change)
        pole = _pole(mode_hz + x[0] * width, zeta * np.exp(x[1]))
        return lsfd(freq_hz, frf, np.r_[pole, near], quantity, win, weight=weight)

    scale = float(np.sum(w[:, None] * np.abs(h) ** 2)) or 1.0

    def cost(x: np.ndarray) -> float:
        if not (abs(x[0]) <= MAX_SHIFT and z_min <= zeta * np.exp(x[1]) < 0.5):
            return _OUTSIDE
        return float(np.sum(w[:, None] * np.abs(h - fit(x).synth) ** 2)) / scale

    simplex = np.array([[0.0, 0.0], [0.3, 0.0], [0.0, 0.3]])
    x = minimize(cost, simplex[0], method="Nelder-Mead", options={
        "initial_simplex": simplex, "xatol": 1e-3, "fatol": 1e-6, "maxiter": 200}).x
    res = fit(x)
    f_r, z_r = mode_hz + x[0] * width, zeta * np.exp(x[1])
    lam = _pole(f_r, z_r)
    s = 2j * np.pi * freq_hz[sel][:, None]
    a = res.residue[:, :1]  # (n_frf, 1): the mode's residues across the FRFs
    term = s ** QUANTITY_POWER[quantity] * (a.T / (s - lam) + np.conj(a.T) / (s - np.conj(lam)))
    misfit = np.sqrt(np.sum(w[:, None] * np.abs(h - res.synth) ** 2) / (w.sum() * h.shape[1]))
    power = np.mean(np.abs(term) ** 2, axis=1) / max(misfit, 1e-300) ** 2  # (lines,)
    in_hp = np.abs(freq_hz[sel] - f_r) <= z_r * f_r
    evidence = np.sqrt(power[in_hp].sum()) if in_hp.any() else np.sqrt(power.max())
    return LocalSupport(snr=float(np.sqrt(power.max())), evidence=float(evidence),
                        lines=int(in_hp.sum()), freq_hz=float(f_r), damping_ratio=float(z_r),
                        mpc=float(mpc(a)[0]), shift=float(abs(x[0])))
