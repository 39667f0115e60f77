"""Stabilisation diagram of an LSCF sweep and automatic selection of the physical poles.

A pole of order p is *stable* when the nearest pole of order p-1 (nearest in lambda) has
    |f - f'| / f < tol_freq,  |zeta - zeta'| / zeta < tol_damping,  MAC(shape, shape') > min_mac.
Physical poles come back at (almost) every order with the same frequency, damping and shape;
noise poles wander. Selection (no human picking):

1. candidates: poles stable in all three criteria, 0 < zeta < max_damping, inside the band;
2. average-linkage clustering of the candidates with the distance
       d_ij = max(|f_i - f_j| / (f_ij tol_cluster_freq), (1 - MAC_ij) / (1 - min_mac));
   clusters are cut at d = 1 and have at most one pole per order;
3. a cluster is a mode when it holds poles from at least ``min_fraction`` of the orders;
4. the mode's pole is the median frequency and damping of its cluster; its uncertainty is the
   standard deviation over the cluster (spread over model orders);
5. modes whose shape estimate has modal phase collinearity below ``min_mpc`` are rejected.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.cluster.hierarchy import fcluster, linkage

from ema.poles.lscf import PoleSweep
from ema.shapes.complexity import mpc
from ema.shapes.mac import mac


@dataclass(frozen=True)
class Stability:
    """Per-pole flags of the stabilisation diagram (aligned with the PoleSweep arrays)."""

    freq: np.ndarray
    damping: np.ndarray
    shape: np.ndarray

    @property
    def all(self) -> np.ndarray:
        return self.freq & self.damping & self.shape


@dataclass(frozen=True)
class SelectedPoles:
    """Automatically selected physical poles, ascending in frequency.

    Attributes:
        freq_hz, damping_ratio: (m,) median over the cluster.
        freq_std_hz, damping_std: (m,) standard deviation over the cluster.
        pole: (m,) lambda = -zeta w_n + i w_n sqrt(1 - zeta^2), rad/s.
        count: (m,) number of model orders at which the mode is stable.
        shape: (m, l) shape estimate of the cluster member nearest the median.
    """

    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    freq_std_hz: np.ndarray
    damping_std: np.ndarray
    pole: np.ndarray
    count: np.ndarray
    shape: np.ndarray


def stability(
    sweep: PoleSweep, tol_freq: float = 0.01, tol_damping: float = 0.05, min_mac: float = 0.95
) -> Stability:
    """Stability flags of every pole against the poles of the previous order of the sweep."""
    n = sweep.pole.size
    fs, ds, ss = (np.zeros(n, dtype=bool) for _ in range(3))
    for p_prev, p in zip(sweep.orders[:-1], sweep.orders[1:], strict=True):
        cur = np.flatnonzero(sweep.order == p)
        prev = np.flatnonzero(sweep.order == p_prev)
        if cur.size == 0 or prev.size == 0:
            continue
        dist = np.abs(sweep.pole[cur, None] - sweep.pole[None, prev])
        near = prev[np.argmin(dist, axis=1)]
        f, f0 = sweep.freq_hz[cur], sweep.freq_hz[near]
        z, z0 = sweep.damping_ratio[cur], sweep.damping_ratio[near]
        fs[cur] = np.abs(f - f0) <= tol_freq * f
        ds[cur] = np.abs(z - z0) <= tol_damping * np.abs(z)
        a, b = sweep.shape[cur], sweep.shape[near]
        num = np.abs(np.sum(np.conj(a) * b, axis=1)) ** 2
        den = np.sum(np.abs(a) ** 2, axis=1) * np.sum(np.abs(b) ** 2, axis=1)
        ss[cur] = num >= min_mac * np.where(den > 0, den, np.inf)
    return Stability(freq=fs, damping=ds, shape=ss)


def select_poles(
    sweep: PoleSweep,
    stab: Stability,
    max_damping: float = 0.1,
    min_mac: float = 0.95,
    tol_cluster_freq: float = 0.003,
    min_fraction: float = 0.3,
    min_mpc: float = 0.5,
    freq_range_hz: tuple[float, float] | None = None,
) -> SelectedPoles:
    """Cluster the stable poles over orders and keep the clusters that are physical modes.

    Poles are candidates inside ``freq_range_hz`` (default: the sweep's band).
    """
    lo, hi = sweep.band_hz if freq_range_hz is None else freq_range_hz
    cand = np.flatnonzero(
        stab.all
        & (sweep.damping_ratio > 0)
        & (sweep.damping_ratio < max_damping)
        & (sweep.freq_hz > lo)
        & (sweep.freq_hz < hi)
    )
    min_count = max(3, int(np.ceil(min_fraction * sweep.orders.size)))
    modes: list[np.ndarray] = []
    if cand.size >= 2:
        f = sweep.freq_hz[cand]
        df = np.abs(f[:, None] - f[None, :]) / (0.5 * (f[:, None] + f[None, :]))
        dmac = (1.0 - mac(sweep.shape[cand].T, sweep.shape[cand].T)) / (1.0 - min_mac)
        d = np.maximum(df / tol_cluster_freq, dmac)
        same_order = sweep.order[cand][:, None] == sweep.order[cand][None, :]
        d[same_order] = np.maximum(d[same_order], 2.0)  # never two poles of one order
        np.fill_diagonal(d, 0.0)
        iu = np.triu_indices(cand.size, 1)
        labels = fcluster(linkage(d[iu], method="average"), t=1.0, criterion="distance")
        for lab in np.unique(labels):
            members = cand[labels == lab]
            # at most one pole per order: keep the one nearest the cluster median frequency
            fm = np.median(sweep.freq_hz[members])
            order_rank = np.lexsort((np.abs(sweep.freq_hz[members] - fm), sweep.order[members]))
            members = members[order_rank]
            _, first = np.unique(sweep.order[members], return_index=True)
            members = members[first]
            if members.size >= min_count:
                modes.append(members)
    rows = []
    for members in modes:
        f = sweep.freq_hz[members]
        z = sweep.damping_ratio[members]
        fm, zm = np.median(f), np.median(z)
        rep = members[np.argmin(np.abs(f - fm) / fm + np.abs(z - zm) / zm)]
        if mpc(sweep.shape[rep][:, None])[0] < min_mpc:
            continue
        rows.append((fm, zm, np.std(f), np.std(z), members.size, sweep.shape[rep]))
    rows.sort(key=lambda r: r[0])
    fr = np.array([r[0] for r in rows], dtype=float)
    zr = np.array([r[1] for r in rows], dtype=float)
    wn = 2 * np.pi * fr
    n_out = sweep.shape.shape[1]
    return SelectedPoles(
        freq_hz=fr,
        damping_ratio=zr,
        freq_std_hz=np.array([r[2] for r in rows], dtype=float),
        damping_std=np.array([r[3] for r in rows], dtype=float),
        pole=-zr * wn + 1j * wn * np.sqrt(1 - zr**2),
        count=np.array([r[4] for r in rows], dtype=int),
        shape=np.array([r[5] for r in rows], dtype=complex).reshape(-1, n_out),
    )
