"""Automatic LSCF poles over a wide band, fitted in overlapping sub-bands.

A single z-domain model over 20-3200 Hz needs a very high order before two close modes at
150 Hz separate (they sit in a small arc of the unit circle), while a model of 20-400 Hz with
dt = 1 / (2 x 400 Hz) separates them at order 20-30. So the band is cut into *core* bands
whose edges double (lo, max(2 lo, lo + 80 Hz), then x2 up to hi); each core is fitted
(``ema.poles.lscf``) over itself widened by ``overlap`` of its width on both sides, and its poles
selected automatically (``ema.poles.stabilisation``). A mode is taken from the sub-band whose
core holds it; modes found twice near a core edge (within ``dup_tol`` in frequency and
20 % in damping) are kept once, from the sub-band whose core centre is nearest. Stable poles
outside the whole band or closer to its edges than their half-power half-width zeta f plus
2 lines (a mode the band edge cuts: its estimate is unreliable) are returned apart, and so
are all poles of the highest order in that edge zone (up to 10 % beyond the band; damping
0-20 %): the LSFD step uses them as computational poles that absorb the cut modes, they are
not reported as modes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema.poles.lscf import PoleSweep, lscf_sweep
from ema.poles.rejected import Rejection
from ema.poles.stabilisation import SelectedPoles, Stability, select_poles, stability

MERGE_OVERLAP = 1.4  # two poles closer than zeta f / MERGE_OVERLAP are one mode (or unresolvable)


@dataclass(frozen=True)
class AutoPoles:
    """Selected modes in the band, extra poles just outside it, and the stabilisation data."""

    modes: SelectedPoles
    outside: SelectedPoles
    computational: np.ndarray
    sweep: PoleSweep
    stability: Stability
    sub_bands: list
    rejected: list[Rejection]


def sub_bands(
    band_hz: tuple[float, float], overlap: float = 0.25, shift: float = 1.0
) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """Cut band_hz into [(core, fitted band), ...] (see module docstring).

    Parameters
    ----------
    band_hz : tuple of float
        (lo, hi) band, Hz.
    overlap : float
        Each core is widened by this fraction of its width on both sides.
    shift : float
        Multiplies the inner core edges (the second partition uses sqrt 2: its core centres sit
        on the first partition's core edges).

    Returns
    -------
    list of tuple
        ((core lo, core hi), (fitted lo, fitted hi)) per sub-band, Hz.
    """
    lo, hi = band_hz
    edges = [lo, max(2 * lo, lo + 80.0) * shift]
    while edges[-1] < hi:
        edges.append(2 * edges[-1])
    edges[-1] = hi
    if len(edges) > 2 and (edges[-1] - edges[-2]) < 0.3 * (edges[-2] - edges[-3]):
        del edges[-2]
    out = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        w = overlap * (b - a)
        out.append(((a, b), (max(lo, a - w), min(hi, b + w))))
    return out


def take(sel: SelectedPoles, keep: np.ndarray) -> SelectedPoles:
    """Return the selected poles where ``keep`` holds.

    Parameters
    ----------
    sel : SelectedPoles
        The poles.
    keep : ndarray
        A boolean mask or indices.

    Returns
    -------
    SelectedPoles
        The poles kept.
    """
    return SelectedPoles(
        freq_hz=sel.freq_hz[keep],
        damping_ratio=sel.damping_ratio[keep],
        freq_std_hz=sel.freq_std_hz[keep],
        damping_std=sel.damping_std[keep],
        pole=sel.pole[keep],
        count=sel.count[keep],
        shape=sel.shape[keep],
    )


def _concat(parts: list[SelectedPoles], n_out: int) -> SelectedPoles:
    if not parts:
        e = np.zeros(0)
        return SelectedPoles(e, e, e, e, e.astype(complex), e.astype(int),
                             np.zeros((0, n_out), complex))
    order = np.argsort(np.concatenate([p.freq_hz for p in parts]))
    cat = SelectedPoles(
        freq_hz=np.concatenate([p.freq_hz for p in parts]),
        damping_ratio=np.concatenate([p.damping_ratio for p in parts]),
        freq_std_hz=np.concatenate([p.freq_std_hz for p in parts]),
        damping_std=np.concatenate([p.damping_std for p in parts]),
        pole=np.concatenate([p.pole for p in parts]),
        count=np.concatenate([p.count for p in parts]),
        shape=np.concatenate([p.shape for p in parts], axis=0),
    )
    return take(cat, order)


def _distinct(poles: np.ndarray, taken: np.ndarray, tol: float = 0.005) -> np.ndarray:
    """Return the poles not within tol (relative |d lambda| / |lambda|) of ``taken``.

    Nor within tol of each other: near-copies would make collinear LSFD columns.
    """
    out: list[complex] = []
    for lam in poles[np.argsort(np.abs(poles))]:
        ref = np.r_[taken, out]
        if ref.size == 0 or np.min(np.abs(ref - lam)) > tol * abs(lam):
            out.append(lam)
    return np.asarray(out, dtype=complex)


def auto_poles(
    freq_hz: np.ndarray,
    frf: np.ndarray,
    band_hz: tuple[float, float],
    max_order: int = 40,
    dup_tol: float = 0.003,
    order_step: int = 1,
) -> AutoPoles:
    """Select the physical poles in band_hz of frf automatically.

    Two partitions into sub-bands are fitted, the second with its core edges shifted by
    sqrt 2 (``sub_bands``): a mode near a core edge of one (where it is fitted off-centre and
    may fall short of the stability criterion) sits mid-core in the other. The modes are the
    union (a second-partition mode within the duplicate tolerance of a first-partition one is
    the same mode), so which modes are found depends much less on where the band starts and
    ends: a mode found in a sub-band is found in the full band. The stabilisation data and
    computational poles are the first partition's.

    Parameters
    ----------
    freq_hz : ndarray
        (F,) lines, Hz.
    frf : ndarray
        (F, l, m) FRFs in the polyreference orientation.
    band_hz : tuple of float
        (lo, hi) band, Hz.
    max_order : int
        Highest LSCF order per sub-band.
    dup_tol : float
        Relative frequency within which two sub-bands' modes are one.
    order_step : int
        Fit every order_step-th order.

    Returns
    -------
    AutoPoles
        The modes, the poles just outside the band, computational poles, the stabilisation
        data and the rejections.
    """
    one = _partition_poles(freq_hz, frf, band_hz, max_order, dup_tol, order_step, 1.0)
    two = _partition_poles(freq_hz, frf, band_hz, max_order, dup_tol, order_step, np.sqrt(2))
    a, b = one.modes, two.modes
    new = np.ones(b.freq_hz.size, dtype=bool)
    for k in range(b.freq_hz.size):
        tol = max(dup_tol, 0.5 * b.damping_ratio[k]) * b.freq_hz[k]
        new[k] = not np.any(np.abs(a.freq_hz - b.freq_hz[k]) <= tol)
    modes, merged_away = merge_overlapping(_concat([a, take(b, new)], a.shape.shape[1]))
    found = modes.freq_hz

    def explained(r: Rejection) -> bool:  # a rejection that the other partition overturned
        return bool(np.any(np.abs(found - r.freq_hz) <= max(dup_tol, 0.5 * r.damping_ratio)
                           * r.freq_hz))

    rejected = [r for r in one.rejected + two.rejected if not explained(r)] + merged_away
    unique: dict[tuple[str, float], Rejection] = {}
    for r in rejected:  # the same candidate rejected by both partitions: listed once
        unique.setdefault((r.reason, round(r.freq_hz, 0)), r)
    return AutoPoles(modes, one.outside, one.computational, one.sweep, one.stability,
                     one.sub_bands, sorted(unique.values(), key=lambda r: r.freq_hz))


def _partition_poles(
    freq_hz: np.ndarray,
    frf: np.ndarray,
    band_hz: tuple[float, float],
    max_order: int,
    dup_tol: float,
    order_step: int,
    shift: float,
) -> AutoPoles:
    """``auto_poles`` over one partition into sub-bands (``sub_bands(band_hz, shift=shift)``)."""
    freq_hz = np.asarray(freq_hz, dtype=float)
    df = freq_hz[1] - freq_hz[0]
    n_out = frf.shape[1]
    lo, hi = band_hz
    found, outside, sweeps, stabs, computational = [], [], [], [], []
    rejected: list[Rejection] = []
    for (a, b), (fa, fb) in sub_bands(band_hz, shift=shift):
        n_lines = int((fb - fa) / df)
        p = min(int(max_order), n_lines // 4)
        if p < 4:
            continue
        sw = lscf_sweep(freq_hz, frf, (fa, fb), p, order_step=order_step)
        st = stability(sw)
        wide, why = select_poles(sw, st, freq_range_hz=(0.9 * fa, 1.1 * fb))
        centre = np.sqrt(a * b)
        tol = np.maximum(dup_tol, 0.5 * wide.damping_ratio)
        in_core = (wide.freq_hz >= a * (1 - tol)) & (wide.freq_hz <= b * (1 + tol))
        guard = wide.damping_ratio * wide.freq_hz + 2 * df
        inside = (wide.freq_hz > lo + guard) & (wide.freq_hz < hi - guard)
        found.append((take(wide, in_core & inside), centre))
        rejected += [r for r in why if a <= r.freq_hz < b or (b >= hi and r.freq_hz == b)]
        for f_r, z_r in zip(wide.freq_hz[in_core & ~inside & (wide.freq_hz >= lo)
                                         & (wide.freq_hz <= hi)],
                            wide.damping_ratio[in_core & ~inside & (wide.freq_hz >= lo)
                                               & (wide.freq_hz <= hi)], strict=True):
            rejected.append(Rejection(float(f_r), float(z_r), "band_edge",
                                      f"within {z_r * f_r + 2 * df:.3g} Hz (zeta f + 2 lines) "
                                      f"of the band edge"))
        edge = ~inside & (((wide.freq_hz > 0.5 * (a + b)) & (b >= hi)) |
                          ((wide.freq_hz < 0.5 * (a + b)) & (a <= lo)))
        outside.append(take(wide, edge))
        # computational poles: every pole of the highest order at the band's edges
        top = sw.order == sw.orders[-1]
        zt, ft = sw.damping_ratio, sw.freq_hz
        g = zt * ft + 2 * df
        comp = top & (zt > 0) & (zt < 0.2) & (
            ((b >= hi) & (ft >= hi - g) & (ft <= 1.1 * hi)) |
            ((a <= lo) & (ft <= lo + g) & (ft >= 0.9 * lo)))
        computational.append(sw.pole[comp])
        # stabilisation data: the poles of this sub-band's core
        core = (sw.freq_hz >= a) & (sw.freq_hz < b if b < hi else sw.freq_hz <= hi)
        sweeps.append((sw, core))
        stabs.append(st)
    if not sweeps:
        raise ValueError(f"band {lo:g}-{hi:g} Hz has too few lines ({df:g} Hz apart) for LSCF")
    # drop duplicates near core edges: keep the estimate from the nearest core centre
    parts = []
    for i, (sel, centre) in enumerate(found):
        keep = np.ones(sel.freq_hz.size, dtype=bool)
        for j, (other, c2) in enumerate(found):
            if j == i or other.freq_hz.size == 0 or sel.freq_hz.size == 0:
                continue
            zeta = 0.5 * (sel.damping_ratio[:, None] + other.damping_ratio[None, :])
            close = np.abs(sel.freq_hz[:, None] / other.freq_hz[None, :] - 1) < np.maximum(
                dup_tol, 0.5 * zeta)
            close &= np.abs(sel.damping_ratio[:, None] / other.damping_ratio[None, :] - 1) < (
                0.2 * np.maximum(1.0, zeta / 0.01))
            dist_self = np.abs(np.log(sel.freq_hz / centre))
            dist_other = np.abs(np.log(other.freq_hz[None, :] / c2))
            worse = close & ((dist_self[:, None] > dist_other) |
                             ((dist_self[:, None] == dist_other) & (j < i)))
            keep &= ~worse.any(axis=1)
        parts.append(take(sel, keep))
    modes, merged_away = merge_overlapping(_concat(parts, n_out))
    rejected += merged_away
    out = _concat(outside, n_out)
    merged = PoleSweep(
        order=np.concatenate([s.order[c] for s, c in sweeps]),
        pole=np.concatenate([s.pole[c] for s, c in sweeps]),
        freq_hz=np.concatenate([s.freq_hz[c] for s, c in sweeps]),
        damping_ratio=np.concatenate([s.damping_ratio[c] for s, c in sweeps]),
        shape=np.concatenate([s.shape[c] for s, c in sweeps], axis=0),
        participation=np.concatenate([s.participation[c] for s, c in sweeps], axis=0),
        orders=np.unique(np.concatenate([s.orders for s, _ in sweeps])),
        band_hz=(lo, hi),
    )
    merged_stab = Stability(
        freq=np.concatenate([st.freq[c] for st, (_, c) in zip(stabs, sweeps, strict=True)]),
        damping=np.concatenate([st.damping[c] for st, (_, c) in zip(stabs, sweeps, strict=True)]),
        shape=np.concatenate([st.shape[c] for st, (_, c) in zip(stabs, sweeps, strict=True)]),
    )
    return AutoPoles(
        modes, out, _distinct(np.concatenate(computational), out.pole), merged, merged_stab,
        [fb for _, fb in sub_bands(band_hz, shift=shift)],
        sorted(rejected, key=lambda r: r.freq_hz),
    )


def overlapping(
    f1_hz: np.ndarray | float, zeta1: np.ndarray | float, f2_hz: np.ndarray | float,
    zeta2: np.ndarray | float,
) -> np.ndarray | bool:
    """Return whether two poles sit inside one half-power width (``MERGE_OVERLAP``).

    True where |f2 - f1| x ``MERGE_OVERLAP`` < (zeta1 f1 + zeta2 f2) / 2: one mode, or a pair
    the data do not resolve. Broadcasts over arrays (Hz, damping ratios).
    """
    half = 0.5 * (np.multiply(zeta1, f1_hz) + np.multiply(zeta2, f2_hz))
    return np.abs(np.subtract(f2_hz, f1_hz)) * MERGE_OVERLAP < half


def merge_overlapping(sel: SelectedPoles) -> tuple[SelectedPoles, list[Rejection]]:
    """Keep one mode where two selected poles sit inside one half-power width.

    Two poles closer than zeta f / ``MERGE_OVERLAP`` (modal overlap above 1.4, zeta f the
    mean half-power half-width) cannot be told apart from one mode whose peak moves between
    the FRFs (inconsistent data) or a pair the data do not resolve: the pole stable at more
    orders is kept, the other reported as ``merged``.

    Parameters
    ----------
    sel : SelectedPoles
        The selected poles, ascending in frequency.

    Returns
    -------
    SelectedPoles
        The poles kept.
    list of Rejection
        The merged ones.
    """
    keep = np.ones(sel.freq_hz.size, dtype=bool)
    out: list[Rejection] = []
    for i in range(1, sel.freq_hz.size):
        j = np.flatnonzero(keep[:i])
        if j.size == 0:
            continue
        j = j[-1]
        f1, f2 = sel.freq_hz[j], sel.freq_hz[i]
        if not overlapping(f1, sel.damping_ratio[j], f2, sel.damping_ratio[i]):
            continue
        half = 0.5 * (sel.damping_ratio[j] * f1 + sel.damping_ratio[i] * f2)
        lose, win = (i, j) if sel.count[i] <= sel.count[j] else (j, i)
        keep[lose] = False
        out.append(Rejection(
            float(sel.freq_hz[lose]), float(sel.damping_ratio[lose]), "merged",
            f"{abs(f2 - f1) / f1:.2%} from the mode at {sel.freq_hz[win]:.4g} Hz, inside its "
            f"half-power width (modal overlap {half / (f2 - f1):.1f}): reported as one mode"))
    return take(sel, keep), out
