"""Per-mode warnings and close pairs: what a fitted mode's numbers cannot be trusted for.

- **Under-resolved damping**: the half-power bandwidth 2 zeta f is narrower than the line
  spacing df: the peak is sampled by one line or none and zeta is a model extrapolation.
- **Leakage**: an impact response decays as exp(-zeta w t); the record behind an FRF with
  line spacing df lasts T = 1/df, so the mode's envelope at the end of the record is
  exp(-2 pi zeta f / df). Above ``LEAK_LEVEL`` (5 %) the response was cut before it decayed:
  the peak is smeared and zeta over-estimated (unless an exponential window, stated in the
  file, made it decay: then the window's damping is part of the fitted zeta and this check
  uses the fitted, windowed zeta).
- **Low coherence**: the mean ordinary coherence over the mode's half-power band (at least
  the nearest line), over the FRFs, is below ``MIN_COHERENCE`` (0.8).
- **Close pairs**: two modes closer than ``CLOSE_PAIR`` (6.5 %) in frequency: a bat tapped off
  its grain axes shows every bending mode as such a pair (split 0.3-6 %); each keeps its own
  shape; the pair is reported with its separation, modal overlap
  (mean zeta f / separation) and the MAC of the two shapes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema.shapes.mac import mac

LEAK_LEVEL = 0.05
MIN_COHERENCE = 0.8
CLOSE_PAIR = 0.065  # the 0.3-6 % splits of a bat tapped off its grain axes, with a margin


@dataclass(frozen=True)
class ClosePair:
    """Modes i < j (indices into the fit's modes) closer than ``CLOSE_PAIR``."""

    i: int
    j: int
    separation: float
    modal_overlap: float
    mac: float


def mode_warnings(
    freq_hz: np.ndarray,
    damping_ratio: np.ndarray,
    df_hz: float,
    coherence: np.ndarray | None = None,
    coherence_freq_hz: np.ndarray | None = None,
) -> list[list[str]]:
    """Return the warnings of each mode (module docstring).

    Parameters
    ----------
    freq_hz : ndarray
        (m,) natural frequencies, Hz.
    damping_ratio : ndarray
        (m,) fitted damping ratios (exponential window included).
    df_hz : float
        Line spacing, Hz.
    coherence : ndarray, optional
        (F, ...) ordinary coherence on ``coherence_freq_hz``.
    coherence_freq_hz : ndarray, optional
        (F,) lines of ``coherence``, Hz.

    Returns
    -------
    list of list of str
        Per mode, what its numbers cannot be trusted for.
    """
    out: list[list[str]] = []
    for f, z in zip(np.asarray(freq_hz, float), np.asarray(damping_ratio, float), strict=True):
        w: list[str] = []
        if 2 * z * f < df_hz:
            w.append(f"under-resolved damping: half-power bandwidth 2 zeta f = {2 * z * f:.3g} "
                     f"Hz < line spacing {df_hz:.3g} Hz")
        envelope = np.exp(-2 * np.pi * z * f / df_hz)
        if envelope > LEAK_LEVEL:
            w.append(f"leakage: the response is still at {envelope:.0%} of its start at the end "
                     f"of the {1 / df_hz:.3g} s record (1/df)")
        if coherence is not None and coherence_freq_hz is not None:
            near = np.abs(coherence_freq_hz - f) <= max(z * f, 0.5 * df_hz)
            if near.any():
                c = float(np.nanmean(np.asarray(coherence)[near]))
                if c < MIN_COHERENCE:
                    w.append(f"low coherence: mean {c:.2f} over the half-power band "
                             f"(< {MIN_COHERENCE:g})")
        out.append(w)
    return out


def close_pairs(
    freq_hz: np.ndarray, damping_ratio: np.ndarray, shapes: np.ndarray
) -> list[ClosePair]:
    """Return the neighbouring modes closer than ``CLOSE_PAIR`` relative in frequency.

    Parameters
    ----------
    freq_hz : ndarray
        (m,) natural frequencies, ascending, Hz.
    damping_ratio : ndarray
        (m,) damping ratios.
    shapes : ndarray
        (n, m) real shapes (for the pair's MAC).

    Returns
    -------
    list of ClosePair
        Each pair with its separation, modal overlap and MAC.
    """
    f = np.asarray(freq_hz, float)
    z = np.asarray(damping_ratio, float)
    pairs = []
    for i in range(f.size - 1):
        j = i + 1
        sep = (f[j] - f[i]) / f[i]
        if sep < CLOSE_PAIR:
            overlap = 0.5 * (z[i] * f[i] + z[j] * f[j]) / max(f[j] - f[i], 1e-300)
            m = float(mac(shapes[:, [i]], shapes[:, [j]])[0, 0]) if shapes.shape[0] else 1.0
            pairs.append(ClosePair(i, j, float(sep), float(overlap), m))
    return pairs
