"""FRF estimation from accepted hits: H1, H2 and ordinary coherence.

With spectra F_k, Y_k of hit k (rfft of the windowed records) and G_xy = sum_k conj(X_k) Y_k:

    H1 = G_fy / G_ff,   H2 = G_yy / G_yf,   coherence = |G_fy|^2 / (G_ff G_yy) = H1 / H2.

Windows: a force window keeps the force from the record start to the end of the pulse plus a
margin and tapers it to zero (removes hammer-channel noise after the hit); the same
exponential window w(t) = exp(-t / tau), t from the record start, multiplies both channels.
Because exp(-t/tau) = exp(-(t-s)/tau) exp(-s/tau), windowing both channels is exactly the
FRF of the structure with every pole moved left by 1/tau: each mode's damping ratio grows by

    delta_zeta_r = 1 / (tau w_r)

which a fitter removes (``added_damping_ratio``). Spectrum scaling cancels in the ratios, so
no window amplitude correction enters the FRF itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FrfEstimate:
    """H1, H2 (response per force, SI) and coherence on ``freq_hz`` from ``n_averages`` hits."""

    freq_hz: np.ndarray
    h1: np.ndarray
    h2: np.ndarray
    coherence: np.ndarray
    n_averages: int
    exp_window_tau_s: float | None


def added_damping_ratio(freq_hz: np.ndarray, tau_s: float | None) -> np.ndarray:
    """Return the damping ratio an exponential window (time constant tau) adds: 1/(tau 2 pi f)."""
    f = np.asarray(freq_hz, dtype=float)
    if tau_s is None:
        return np.zeros_like(f)
    return 1.0 / (tau_s * 2 * np.pi * f)


def exponential_window(n: int, sample_rate_hz: float, tau_s: float | None) -> np.ndarray:
    """Return the window exp(-t / tau) at t = k / fs (n samples); ones when tau is None."""
    if tau_s is None:
        return np.ones(n)
    return np.exp(-np.arange(n) / (sample_rate_hz * tau_s))


def force_window(force_n: np.ndarray, sample_rate_hz: float, margin_s: float = 0.002,
                 taper_s: float = 0.001, threshold_fraction: float = 0.02) -> np.ndarray:
    """Build (k, n) force windows that keep the pulse and cut the noise after it.

    Each window is 1 up to the end of the pulse (last sample above threshold_fraction of the
    peak) plus ``margin_s``, then a half-cosine taper of ``taper_s`` to zero.
    """
    f = np.atleast_2d(force_n)
    k, n = f.shape
    above = f > threshold_fraction * f.max(axis=1, keepdims=True)
    last = n - 1 - np.argmax(above[:, ::-1], axis=1)
    end = np.minimum(last + int(round(margin_s * sample_rate_hz)), n)
    m = max(int(round(taper_s * sample_rate_hz)), 1)
    idx = np.arange(n)[None, :] - end[:, None]
    taper = 0.5 * (1 + np.cos(np.pi * np.clip(idx, 0, m) / m))
    return np.where(idx < 0, 1.0, np.where(idx < m, taper, 0.0))


def estimate_frf(force_n: np.ndarray, response: np.ndarray, sample_rate_hz: float,
                 exp_window_tau_s: float | None = None, use_force_window: bool = True,
                 fmax_hz: float | None = None) -> FrfEstimate:
    """Estimate H1, H2 and coherence from (k, n) force and response records.

    H1 = G_fy / G_ff, H2 = G_yy / G_yf, coherence = |G_fy|^2 / (G_ff G_yy), the spectra summed
    over the k records (module docstring).

    Parameters
    ----------
    force_n : np.ndarray
        (k, n) force records, N.
    response : np.ndarray
        (k, n) response records (acceleration, m/s^2), sample for sample with the force.
    sample_rate_hz : float
        Sampling rate, Hz.
    exp_window_tau_s : float or None, optional
        Time constant of an exponential window on both records, s; None for none.
    use_force_window : bool, optional
        Cut the force record after the pulse (``force_window``); default True.
    fmax_hz : float or None, optional
        Highest frequency line kept, Hz; None keeps up to Nyquist.

    Returns
    -------
    FrfEstimate
        The estimates on the rfft lines, (m/s^2)/N, with the window used and k.
    """
    f = np.atleast_2d(np.asarray(force_n, dtype=float))
    y = np.atleast_2d(np.asarray(response, dtype=float))
    if f.shape != y.shape or f.shape[0] == 0:
        raise ValueError(f"force and response records differ or are empty: {f.shape} {y.shape}")
    n = f.shape[1]
    w_exp = exponential_window(n, sample_rate_hz, exp_window_tau_s)
    wf = force_window(f, sample_rate_hz) if use_force_window else 1.0
    F = np.fft.rfft(f * wf * w_exp, axis=1)
    Y = np.fft.rfft(y * w_exp, axis=1)
    freq = np.fft.rfftfreq(n, 1.0 / sample_rate_hz)
    if fmax_hz is not None:
        keep = freq <= fmax_hz + 1e-9
        freq, F, Y = freq[keep], F[:, keep], Y[:, keep]
    gff = np.sum(np.abs(F) ** 2, axis=0)
    gyy = np.sum(np.abs(Y) ** 2, axis=0)
    gfy = np.sum(np.conj(F) * Y, axis=0)
    tiny = np.finfo(float).tiny
    h1 = gfy / np.maximum(gff, tiny)
    h2 = gyy / np.where(np.abs(gfy) > tiny, np.conj(gfy), tiny)
    coh = np.abs(gfy) ** 2 / np.maximum(gff * gyy, tiny)
    return FrfEstimate(freq, h1, h2, np.clip(coh, 0.0, 1.0), f.shape[0], exp_window_tau_s)
