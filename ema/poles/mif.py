"""Mode indicator functions and peak picking with half-power damping (the quick method).

- Sum MIF: S(f) = sum_jk |H_jk(f)|^2 (power sum over all FRFs).
- CMIF (Shih, Tsuei, Allemang, Brown 1988): singular values of H(f) (n_resp x n_ref) per line,
  descending; a peak of the first singular value marks a mode, a peak of the second a repeated
  or close one. With one accelerometer the CMIF has one curve, sqrt(S).
- Peak picking: local maxima of S with a prominence of ``min_prominence`` (ratio of the peak to
  the higher of its bounding troughs, in power); damping by half power, zeta = (f2 - f1) /
  (2 f_r) with f1, f2 where S falls to half its peak (Ewins, Modal Testing, 4.3.1). Near a
  light resonance 1/S = a (f - f_r)^2 + a (zeta f_r)^2, so instead of interpolating the
  half-power points between lines (poor when the bandwidth spans 2-3 lines) a parabola is
  fitted to 1/S over the lines above 0.3 x the peak: f_r is its vertex and the half-power
  half-width zeta f_r = sqrt(floor / a).
- Prominence (``prominent_peaks``) as ``scipy.signal.find_peaks`` and ``peak_prominences``
  define it: a peak is a sample or a flat run (its middle sample) higher than both
  neighbours; its prominence is its height less the higher of the lowest points between it
  and the nearest higher sample on each side (or the end). The same peaks, without
  importing scipy.signal (which imports scipy.stats: 0.3-0.8 s of every command's start).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def local_maxima(y: np.ndarray) -> np.ndarray:
    """Return the indices of the local maxima of ``y``, a flat top by its middle sample.

    A run of equal samples is a maximum when the samples either side of it are both lower;
    the first and last samples never are (``scipy.signal.find_peaks`` without conditions).
    """
    y = np.asarray(y, dtype=float)
    if y.size < 3:
        return np.zeros(0, dtype=int)
    start = np.flatnonzero(np.concatenate([[True], y[1:] != y[:-1]]))  # each run's first
    end = np.concatenate([start[1:] - 1, [y.size - 1]])
    v = y[start]
    top = np.flatnonzero((v[1:-1] > v[:-2]) & (v[1:-1] > v[2:])) + 1
    return (start[top] + end[top]) // 2


def prominent_peaks(y: np.ndarray, min_prominence: float) -> np.ndarray:
    """Return the local maxima of ``y`` with a prominence of at least ``min_prominence``.

    The prominence of peak p: y[p] - max(min y[l+1..p], min y[p..r-1]), l and r the nearest
    samples either side higher than y[p] (the ends when there is none), as
    ``scipy.signal.peak_prominences`` (module docstring). One vectorised search per peak.

    Parameters
    ----------
    y : ndarray
        (F,) samples.
    min_prominence : float
        The least prominence kept, in y's units.

    Returns
    -------
    ndarray
        Indices of the peaks kept, ascending.
    """
    y = np.asarray(y, dtype=float)
    peaks = local_maxima(y)
    keep = np.zeros(peaks.size, dtype=bool)
    for n, p in enumerate(peaks):  # one search per peak, none per sample
        higher_left = np.flatnonzero(y[:p] > y[p])
        higher_right = np.flatnonzero(y[p + 1:] > y[p])
        lo = higher_left[-1] + 1 if higher_left.size else 0
        hi = p + 1 + higher_right[0] if higher_right.size else y.size
        base = max(y[lo:p + 1].min(), y[p:hi].min())
        keep[n] = y[p] - base >= min_prominence
    return peaks[keep]


@dataclass(frozen=True)
class PeakPick:
    """Peaks of the sum MIF with half-power damping, ascending in frequency."""

    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    height: np.ndarray


def sum_mif(frf: np.ndarray) -> np.ndarray:
    """Return the power sum over all FRFs.

    Parameters
    ----------
    frf : ndarray
        (F, ...) FRFs.

    Returns
    -------
    ndarray
        (F,) sum of |H|^2 over the FRFs.
    """
    h = np.asarray(frf)
    return np.sum(np.abs(h.reshape(h.shape[0], -1)) ** 2, axis=1)


def receptance_power(freq_hz: np.ndarray, power: np.ndarray, quantity: str) -> np.ndarray:
    """Divide a power MIF of accelerance/mobility by w^4 / w^2: the receptance power sum.

    Its inverse is the parabola about each resonance that ``pick_peaks`` fits.

    Parameters
    ----------
    freq_hz : ndarray
        (F,) lines, Hz.
    power : ndarray
        (F,) power MIF of ``quantity``.
    quantity : str
        "receptance", "mobility" or "accelerance".

    Returns
    -------
    ndarray
        (F,) receptance-equivalent power (0 at 0 Hz).
    """
    q = {"receptance": 0, "mobility": 1, "accelerance": 2}[quantity]
    w = 2 * np.pi * np.asarray(freq_hz, dtype=float)
    with np.errstate(divide="ignore"):
        return np.where(w > 0, np.asarray(power) / np.where(w > 0, w, 1.0) ** (2 * q), 0.0)


def cmif(frf: np.ndarray) -> np.ndarray:
    """Return the singular values of each line's FRF matrix.

    Parameters
    ----------
    frf : ndarray
        (F, n_resp, n_ref) FRFs.

    Returns
    -------
    ndarray
        (F, min(n_resp, n_ref)) singular values, descending.
    """
    return np.linalg.svd(np.asarray(frf, dtype=complex), compute_uv=False)


def pick_peaks(
    freq_hz: np.ndarray,
    mif: np.ndarray,
    band_hz: tuple[float, float],
    min_prominence: float = 4.0,
) -> PeakPick:
    """Pick the peaks of a receptance power MIF in the band, with half-power damping.

    See the module docstring for the parabola fitted to 1 / MIF about each peak.

    Parameters
    ----------
    freq_hz : ndarray
        (F,) lines, Hz.
    mif : ndarray
        (F,) receptance power MIF (``receptance_power``).
    band_hz : tuple of float
        (lo, hi) band, Hz.
    min_prominence : float
        A peak must stand this many times above its surroundings.

    Returns
    -------
    PeakPick
        Frequencies, damping ratios and heights of the peaks.
    """
    freq_hz = np.asarray(freq_hz, dtype=float)
    mif = np.asarray(mif, dtype=float)
    sel = np.flatnonzero((freq_hz >= band_hz[0]) & (freq_hz <= band_hz[1]))
    f, s = freq_hz[sel], np.maximum(mif[sel], np.finfo(float).tiny)
    idx = prominent_peaks(np.log(s), np.log(min_prominence))
    idx = idx[(idx > 0) & (idx < f.size - 1)]
    fr, zeta, ok = np.empty(idx.size), np.empty(idx.size), np.zeros(idx.size, dtype=bool)
    for n, k in enumerate(idx):  # one small fit per peak (not per line)
        # the contiguous lines about the peak above 0.3 x its height, at least k-1..k+1
        below = s < 0.3 * s[k]
        left = np.flatnonzero(below[:k])
        right = np.flatnonzero(below[k:])
        lft = min(left[-1] + 1 if left.size else 0, k - 1)
        rgt = max(k + right[0] - 1 if right.size else f.size - 1, k + 1)
        a2, a1, a0 = np.polyfit(f[lft : rgt + 1] - f[k], 1.0 / s[lft : rgt + 1], 2)
        if a2 <= 0:
            continue
        centre = -a1 / (2 * a2)
        floor = a0 - a2 * centre**2
        if floor <= 0:
            continue
        fr[n] = f[k] + centre
        zeta[n] = np.sqrt(floor / a2) / fr[n]
        ok[n] = True
    return PeakPick(freq_hz=fr[ok], damping_ratio=zeta[ok], height=s[idx][ok])
