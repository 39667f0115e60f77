"""Mode indicator functions and peak picking with half-power damping (the quick method).

- Sum MIF: S(f) = sum_jk |H_jk(f)|^2 (power sum over all FRFs).
- CMIF (Shih, Tsuei, Allemang, Brown 1988): singular values of H(f) (n_resp x n_ref) per line,
  descending; a peak of the first singular value marks a mode, a peak of the second a repeated
  or close one. With one accelerometer the CMIF has one curve, sqrt(S).
- Peak picking: local maxima of S with a prominence of ``min_prominence`` (ratio of the peak to
  the higher of its bounding troughs, in power), frequency by a parabola through the log of
  the three lines about the peak, damping by half power: the band f1..f2 where S falls to half
  its peak, zeta = (f2 - f1) / (2 f_r) (Ewins, Modal Testing, 4.3.1), both ends interpolated
  linearly between lines.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import find_peaks


@dataclass(frozen=True)
class PeakPick:
    """Peaks of the sum MIF with half-power damping, ascending in frequency."""

    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    height: np.ndarray


def sum_mif(frf: np.ndarray) -> np.ndarray:
    """Power sum over all FRFs: frf (F, ...) -> (F,)."""
    h = np.asarray(frf)
    return np.sum(np.abs(h.reshape(h.shape[0], -1)) ** 2, axis=1)


def cmif(frf: np.ndarray) -> np.ndarray:
    """Singular values of each line's FRF matrix: frf (F, n_resp, n_ref) -> (F, min(...))."""
    return np.linalg.svd(np.asarray(frf, dtype=complex), compute_uv=False)


def pick_peaks(
    freq_hz: np.ndarray,
    mif: np.ndarray,
    band_hz: tuple[float, float],
    min_prominence: float = 4.0,
) -> PeakPick:
    """Peaks of a power MIF in the band with half-power damping (see module docstring)."""
    freq_hz = np.asarray(freq_hz, dtype=float)
    mif = np.asarray(mif, dtype=float)
    sel = np.flatnonzero((freq_hz >= band_hz[0]) & (freq_hz <= band_hz[1]))
    f, s = freq_hz[sel], np.maximum(mif[sel], np.finfo(float).tiny)
    ls = np.log(s)
    idx, _ = find_peaks(ls, prominence=np.log(min_prominence))
    idx = idx[(idx > 0) & (idx < f.size - 1)]
    if idx.size == 0:
        empty = np.zeros(0)
        return PeakPick(empty, empty, empty)
    df = f[1] - f[0]
    y0, y1, y2 = ls[idx - 1], ls[idx], ls[idx + 1]
    curv = y0 - 2 * y1 + y2
    shift = np.where(curv < 0, 0.5 * (y0 - y2) / np.where(curv < 0, curv, -1.0), 0.0)
    fr = f[idx] + shift * df
    half = s[idx] / 2
    below = s[None, :] < half[:, None]  # (n_peaks, F)
    lines = np.arange(f.size)[None, :]
    left = np.where(below & (lines < idx[:, None]), lines, -1).max(axis=1)
    right = np.where(below & (lines > idx[:, None]), lines, f.size).min(axis=1)
    ok = (left >= 0) & (right < f.size)
    left, right = np.clip(left, 0, f.size - 2), np.clip(right, 1, f.size - 1)
    # linear interpolation of the crossing between (left, left+1) and (right-1, right)
    fl = f[left] + (half - s[left]) / (s[left + 1] - s[left]) * df
    fh = f[right - 1] + (half - s[right - 1]) / (s[right] - s[right - 1]) * df
    zeta = (fh - fl) / (2 * fr)
    keep = ok & (zeta > 0)
    return PeakPick(freq_hz=fr[keep], damping_ratio=zeta[keep], height=s[idx][keep])
