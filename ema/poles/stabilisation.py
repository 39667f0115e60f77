"""Stabilisation diagram of an LSCF sweep and automatic selection of the physical poles.

A pole of order p is *stable* when the nearest pole of order p-1 (nearest in lambda) has
    |f - f'| / f < tol_freq,  |zeta - zeta'| / zeta < tol_damping,  MAC(shape, shape') > min_mac.
Physical poles come back at (almost) every order with the same frequency, damping and shape;
noise poles wander. Selection (no human picking):

1. candidates: poles stable in all three criteria, 0 < zeta < max_damping, inside the band;
2. average-linkage clustering of the candidates with the distance
       d_ij = max(|f_i - f_j| / (f_ij max(tol_cluster_freq, zeta_ij / 2)),
                  (1 - MAC_ij) / (1 - min_mac));
   clusters are cut at d = 1 and have at most one pole per order;
3. a cluster is a mode when it holds poles from at least ``min_fraction`` of the orders;
4. the mode's pole is the median frequency and damping of its cluster; its uncertainty is the
   standard deviation over the cluster (spread over model orders);
5. modes whose shape estimate has modal phase collinearity below ``min_mpc`` are rejected.
Tolerances widen with the damping (``stability``, step 2): a heavily damped (3-7 %) mode's
estimate moves by a fraction of its half-power width from order to order, and FRFs whose
peaks move ~2 % between points give one smeared pole. Each rejected cluster is reported
(``ema.poles.rejected``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema.poles.lscf import PoleSweep
from ema.poles.rejected import Rejection
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
        """Return the poles stable in frequency, damping and shape."""
        return self.freq & self.damping & self.shape


@dataclass(frozen=True)
class SelectedPoles:
    """Automatically selected physical poles, ascending in frequency.

    Attributes
    ----------
    freq_hz, damping_ratio
        (m,) median over the cluster.
    freq_std_hz, damping_std
        (m,) standard deviation over the cluster.
    pole
        (m,) lambda = -zeta w_n + i w_n sqrt(1 - zeta^2), rad/s.
    count
        (m,) number of model orders at which the mode is stable.
    shape
        (m, l) shape estimate of the cluster member nearest the median.
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
    """Flag every pole's stability against the poles of the previous order of the sweep.

    The tolerances scale with the pole's damping zeta (capped at 10 %): frequency
    max(tol_freq, zeta / 2) (half the half-power half-width), damping tol_damping x
    max(1, zeta / 1 %) relative.

    Parameters
    ----------
    sweep : PoleSweep
        The poles of every order.
    tol_freq : float
        Relative frequency tolerance of a lightly damped pole.
    tol_damping : float
        Relative damping tolerance of a lightly damped pole.
    min_mac : float
        Least MAC between the shape estimates.

    Returns
    -------
    Stability
        Flags per pole: stable in frequency, damping and shape.
    """
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
        # tolerances widen with the damping: a pole's half-power half-width is zeta f, and a
        # heavily damped mode's estimate moves by a fraction of it between orders
        zeta = np.clip(np.abs(z), 0.0, 0.1)
        fs[cur] = np.abs(f - f0) <= np.maximum(tol_freq, 0.5 * zeta) * f
        ds[cur] = np.abs(z - z0) <= tol_damping * np.abs(z) * np.maximum(1.0, zeta / 0.01)
        a, b = sweep.shape[cur], sweep.shape[near]
        num = np.abs(np.sum(np.conj(a) * b, axis=1)) ** 2
        den = np.sum(np.abs(a) ** 2, axis=1) * np.sum(np.abs(b) ** 2, axis=1)
        ss[cur] = num >= min_mac * np.where(den > 0, den, np.inf)
    return Stability(freq=fs, damping=ds, shape=ss)


def _join_smeared(
    sweep: PoleSweep, groups: list[np.ndarray], tol_freq: float
) -> list[np.ndarray]:
    """Join clusters whose median frequencies are within max(tol_freq, zeta / 2) relative.

    A heavily damped mode, or one whose peak moves between the FRFs, shows up at some orders
    as two poles (one per order is allowed in a cluster), fragmenting it into clusters that
    each look unstable; together they are one mode. Two clusters present together at more
    than half the orders of the smaller one are two modes (a close pair) and stay apart.
    """
    med = [(float(np.median(sweep.freq_hz[g])), float(np.median(sweep.damping_ratio[g])), g)
           for g in groups]
    med.sort(key=lambda t: t[0])
    out: list[list] = []
    for fm, zm, g in med:
        if out:
            f0, z0, g0 = out[-1]
            shared = np.intersect1d(sweep.order[g0], sweep.order[g]).size
            if (fm - f0 <= max(tol_freq, 0.25 * (z0 + zm)) * 0.5 * (f0 + fm)
                    and shared <= 0.5 * min(g0.size, g.size)):
                g1 = np.concatenate([g0, g])
                out[-1] = [float(np.median(sweep.freq_hz[g1])),
                           float(np.median(sweep.damping_ratio[g1])), g1]
                continue
        out.append([fm, zm, g])
    return [g for _, _, g in out]


def select_poles(
    sweep: PoleSweep,
    stab: Stability,
    max_damping: float = 0.1,
    min_mac: float = 0.95,
    tol_cluster_freq: float = 0.003,
    min_fraction: float = 0.3,
    min_mpc: float = 0.5,
    freq_range_hz: tuple[float, float] | None = None,
) -> tuple[SelectedPoles, list[Rejection]]:
    """Cluster the stable poles over orders and keep the clusters that are physical modes.

    Poles are candidates inside ``freq_range_hz`` (default: the sweep's band). The cluster
    frequency tolerance widens with the damping: max(tol_cluster_freq, zeta_ij / 2) with
    zeta_ij the pair's mean damping.

    Parameters
    ----------
    sweep : PoleSweep
        The poles of every order.
    stab : Stability
        Their stability flags (``stability``).
    max_damping : float
        Clusters more damped are not modes.
    min_mac : float
        Least MAC within a cluster.
    tol_cluster_freq : float
        Relative frequency tolerance of a cluster (lightly damped).
    min_fraction : float
        Fraction of the orders at which a mode must be stable.
    min_mpc : float
        Least modal phase collinearity of its shape estimate.
    freq_range_hz : tuple of float, optional
        (lo, hi) where candidates are taken, Hz.

    Returns
    -------
    SelectedPoles
        The modes.
    list of Rejection
        Every cluster of at least two stable poles that is not a mode, with why
        (``ema.poles.rejected``).
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
    clusters = _cluster_candidates(sweep, cand, min_mac, tol_cluster_freq)
    rows, rejected = _judge_clusters(sweep, clusters, min_count, min_mpc)
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
    ), rejected


def _cluster_candidates(sweep: PoleSweep, cand: np.ndarray, min_mac: float,
                        tol_cluster_freq: float) -> list[np.ndarray]:
    """Cluster candidate poles by frequency (tolerance widening with damping) and MAC.

    Average-linkage clustering of d = max(df / tol, (1 - MAC) / (1 - min_mac)), two poles of
    one order never together; smeared neighbours joined (``_join_smeared``); at most one pole
    per order kept in each cluster, the one nearest the cluster's median frequency.
    """
    from scipy.cluster.hierarchy import fcluster, linkage  # here: 0.1-0.2 s to import

    if cand.size < 2:
        return []
    f = sweep.freq_hz[cand]
    z = sweep.damping_ratio[cand]
    df = np.abs(f[:, None] - f[None, :]) / (0.5 * (f[:, None] + f[None, :]))
    tol = np.maximum(tol_cluster_freq, 0.25 * (z[:, None] + z[None, :]))
    dmac = (1.0 - mac(sweep.shape[cand].T, sweep.shape[cand].T)) / (1.0 - min_mac)
    d = np.maximum(df / tol, dmac)
    same_order = sweep.order[cand][:, None] == sweep.order[cand][None, :]
    d[same_order] = np.maximum(d[same_order], 2.0)  # never two poles of one order
    np.fill_diagonal(d, 0.0)
    iu = np.triu_indices(cand.size, 1)
    labels = fcluster(linkage(d[iu], method="average"), t=1.0, criterion="distance")
    clusters = []
    for members in _join_smeared(sweep, [cand[labels == lab] for lab in np.unique(labels)],
                                 tol_cluster_freq):
        fm = np.median(sweep.freq_hz[members])
        order_rank = np.lexsort((np.abs(sweep.freq_hz[members] - fm), sweep.order[members]))
        members = members[order_rank]
        _, first = np.unique(sweep.order[members], return_index=True)
        clusters.append(members[first])
    return clusters


def _judge_clusters(sweep: PoleSweep, clusters: list[np.ndarray], min_count: int,
                    min_mpc: float) -> tuple[list[tuple], list[Rejection]]:
    """Keep the clusters stable at ``min_count`` orders with MPC >= ``min_mpc``.

    Returns rows (median frequency and damping, their spreads, count, the representative's
    shape) and the rejections with their reasons.
    """
    rows, rejected = [], []
    for members in clusters:
        f = sweep.freq_hz[members]
        z = sweep.damping_ratio[members]
        fm, zm = float(np.median(f)), float(np.median(z))
        if members.size < min_count:
            if members.size >= 2:
                rejected.append(Rejection(fm, zm, "stability", f"stable at {members.size} of "
                                          f"{sweep.orders.size} orders (needs {min_count})",
                                          int(members.size)))
            continue
        rep = members[np.argmin(np.abs(f - fm) / fm + np.abs(z - zm) / zm)]
        phase = float(mpc(sweep.shape[rep][:, None])[0])
        if phase < min_mpc:
            rejected.append(Rejection(fm, zm, "complexity", f"MPC {phase:.2f} < {min_mpc:g}"))
            continue
        rows.append((fm, zm, np.std(f), np.std(z), members.size, sweep.shape[rep]))
    return rows, rejected
