"""Where the re-test's calipers read less than the registration: a scan with a stated level.

For a run of stations I and a pattern p over the orientations (``uniform``: every
orientation short by the same h, as shaving and a groove's ring make; ``orientation``:
only the readings at one orientation short, as a flat facing it makes), the drops' channels
(``calipers.null``) give, station by station, with the mean channel's variance v_i and the
residual's sigma_re^2:

    a_i = p_m ybar_i / v_i + (Q_i^T p) . (Q_i^T delta_i) / sigma_re^2
    b_i = p_m^2 / v_i + |Q_i^T p|^2 / sigma_re^2,       c_i = p_m / v_i

(p_m the pattern's mean). The generalised likelihood ratio of "the run lost h >= 0 in the
pattern" against the null is

    z = A / sqrt(B + tau_ov^2 C^2 + tau_s^2 C_g^2),    h = A / B,

A, B, C the sums over the run, C_g = sum c_i g_i; tau_ov (the registration's ovality and the
orientations' mean ovality, common along the bat) and tau_s (the shrinkage's uncertainty, in
proportion to g) are the systematic offsets no averaging removes. Runs of
``WINDOW_LENGTHS`` stations at every start and every pattern are scanned; a change is found
where z exceeds the bound u at which Hunter's (1976) improvement of Bonferroni's inequality
over all of them reaches alpha:

    P(max z > u) <= sum_w Q(u) - sum_(w, w') in T P(z_w > u, z_w' > u)
                  = sum_roots Q(u) + sum_(w, w') in T 2 T_Owen(u, sqrt((1 - r) / (1 + r))) = alpha

for any forest T of pairs of windows (Q the normal upper tail; for a bivariate normal pair of
correlation r, ``P(z_w' > u, z_w <= u) = 2 T_Owen(u, sqrt((1 - r) / (1 + r)))``, Owen 1956).
Each window is paired with the one of its earlier neighbours it is most correlated with: the
same run one station earlier, the next shorter run from the same station, or the same run in
an earlier pattern (``critical_z``); r from the stations' cross-information and the common
offsets. The runs overlap heavily (a run of L stations and its shift share L - 1; orientations
90 deg apart have the same residual), so the bound is 0.15-0.2 below Bonferroni's
``Phi^-1(1 - alpha / M)`` (M = patterns x runs), which it never exceeds; a survey of an
unaltered bat is called changed with probability at most alpha (``CALIPER_FALSE_ALARM``) under
the null. A noise level estimated above its floor makes z a
Student's t: its degrees of freedom for a pattern, by Welch and Satterthwaite from the
shares of the pattern's information carried by the mean channel (the registration's noise,
nu_g) and the residual (the caliper's, nu_re), ``1 / nu = s_m^2 / nu_g + s_r^2 / nu_re``;
z is then read on the normal scale, ``Phi^-1(T_nu(z))``, before the bound.

Found runs are taken greedily, largest z first, their ends placed where ``A / sqrt(B)`` is
largest (``local_z``: the common offsets do not say where a run ends), and no later run
overlaps an earlier one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.special import ndtr, ndtri, owens_t, stdtr

from updating.inspect.calipers.null import (
    CaliperNull,
    StationBasis,
    Stations,
    mean_drops,
    mean_variance,
)

CALIPER_FALSE_ALARM = 1e-3
"""The survey's false-alarm level: at most this chance that an unaltered bat's survey shows a
change (Bonferroni over every run and pattern scanned, under the null)."""
WINDOW_LENGTHS = (1, 2, 3, 4, 6, 8, 11, 16, 23, 32, 45, 64)
"""Runs scanned, in stations (factors of about sqrt 2: a change of any length is matched
within 7 % of its statistic by one of them)."""
UNIFORM = 0
"""Index of the ``uniform`` pattern among those scanned (``patterns_for`` puts it first)."""
ANGLE_TOL_DEG = 0.5
"""Orientations closer than this are one orientation."""


@dataclass(frozen=True)
class Pattern:
    """What a change does to a station's readings: every orientation, or one.

    Attributes
    ----------
    name : str
        ``uniform`` or ``orientation``.
    angle_deg : float or None
        The orientation an ``orientation`` pattern shortens.
    """

    name: str
    angle_deg: float | None = None

    def vector(self, angles_deg: np.ndarray) -> np.ndarray:
        """Return the pattern over a station's orientations (1 where read short)."""
        if self.name == "uniform":
            return np.ones(len(angles_deg))
        d = np.abs((np.asarray(angles_deg) - self.angle_deg + 90.0) % 180.0 - 90.0)
        return (d <= ANGLE_TOL_DEG).astype(float)


@dataclass(frozen=True)
class Terms:
    """Each station's terms of the statistic for each pattern (module docstring).

    Attributes
    ----------
    a, b, c : ndarray
        (P, N) per pattern and station.
    bx : ndarray
        (P, P, N) the patterns' cross-information per station (``b`` on its diagonal):
        the covariance of ``a`` between two patterns under the null.
    g_m : ndarray
        (N,) the registered diameters, m.
    tau_ov2, tau_s2 : float
        The systematic offsets' variances (m^2, and relative^2).
    dof : ndarray
        (P,) each pattern's degrees of freedom (infinite: z is normal).
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    bx: np.ndarray
    g_m: np.ndarray
    tau_ov2: float
    tau_s2: float
    dof: np.ndarray

    def normal_z(self, z, k):
        """Return z of pattern(s) ``k`` read on the normal scale (module docstring)."""
        nu = self.dof[k]
        if np.all(np.isinf(nu)):
            return z
        tail = np.clip(stdtr(np.where(np.isinf(nu), 1.0, nu), -np.abs(z)), 1e-300, 0.5)
        return np.where(np.isinf(nu), z, -np.sign(z) * ndtri(tail))  # the tail, not 1 - tail


@dataclass(frozen=True)
class Run:
    """A run of stations read short in a pattern.

    Attributes
    ----------
    pattern : int
        Index into the patterns scanned.
    i0, i1 : int
        The run's stations are ``i0 .. i1 - 1``.
    z, h_m, sd_m : float
        Its statistic, the loss in the pattern (m) and its standard uncertainty.
    """

    pattern: int
    i0: int
    i1: int
    z: float
    h_m: float
    sd_m: float


def patterns_for(st: Stations, bases: list[StationBasis]) -> tuple[Pattern, ...]:
    """Return the patterns worth scanning: uniform, and each orientation a residual can see."""
    out = [Pattern("uniform")]
    if any(b.q.shape[1] for b in bases):
        angles = np.unique(np.round(np.concatenate(st.angles_deg), 3))
        out += [Pattern("orientation", float(a)) for a in angles]
    return tuple(out)


def station_terms(st: Stations, bases: list[StationBasis], null: CaliperNull,
                  patterns: tuple[Pattern, ...]) -> Terms:
    """Compute ``a``, ``b``, ``c`` of every station and pattern (module docstring)."""
    ybar = mean_drops(st, null.scale)
    v = mean_variance(st, null.sigma_retest_m, null.sigma_registration_m) * null.inflation**2
    s2 = null.sigma_retest_m**2
    P, N = len(patterns), st.n
    a, b, c = np.zeros((P, N)), np.zeros((P, N)), np.zeros((P, N))
    bx = np.zeros((P, P, N))
    info_r = np.zeros(P)
    for i in range(N):
        q = bases[i].q
        drops = st.g_m[i] * (1 + null.scale) - st.readings_m[i]
        yr = q.T @ drops
        ps = np.array([pat.vector(st.angles_deg[i]) for pat in patterns])
        pm, pr = ps.mean(axis=1), ps @ q
        a[:, i] = pm * ybar[i] / v[i] + pr @ yr / s2
        bx[:, :, i] = np.outer(pm, pm) / v[i] + pr @ pr.T / s2
        b[:, i] = np.diagonal(bx[:, :, i])
        c[:, i] = pm / v[i]
        info_r += np.einsum("kj,kj->k", pr, pr) / s2
    worst = max((b.mean_ovality for b in bases), default=1.0)
    tau_ov2 = 0.5 * null.ovality_m**2 * (1.0 + worst**2)
    share_r = info_r / np.maximum(b.sum(axis=1), 1e-300)
    with np.errstate(divide="ignore"):
        inv = (1 - share_r) ** 2 / null.dof_registration + share_r**2 / null.dof_retest
        dof = np.where(inv > 0, 1.0 / np.where(inv > 0, inv, 1.0), np.inf)
    return Terms(a, b, c, bx, st.g_m, tau_ov2, null.scale_sd**2, dof)


def window_stats(t: Terms, k: int, i0: int, i1: int) -> tuple[float, float, float]:
    """(z, h, sd of h) of pattern ``k`` over stations ``i0 .. i1 - 1``."""
    A, B = t.a[k, i0:i1].sum(), t.b[k, i0:i1].sum()
    C, Cg = t.c[k, i0:i1].sum(), (t.c[k, i0:i1] * t.g_m[i0:i1]).sum()
    if B <= 0:
        return 0.0, 0.0, np.inf
    var = B + t.tau_ov2 * C**2 + t.tau_s2 * Cg**2
    z = float(t.normal_z(A / np.sqrt(var), k))
    return z, float(A / B), float(np.sqrt(var) / B)


def n_tests(n_stations: int, n_patterns: int) -> int:
    """Return the number of (run, pattern) pairs the scan tests."""
    return n_patterns * sum(n_stations - L + 1 for L in WINDOW_LENGTHS if L <= n_stations)


def bonferroni_z(n_stations: int, n_patterns: int, false_alarm: float) -> float:
    """Bonferroni's bound: ``Phi^-1(1 - alpha / M)`` (module docstring)."""
    return float(ndtri(1.0 - false_alarm / max(n_tests(n_stations, n_patterns), 1)))


def _cum(x: np.ndarray) -> np.ndarray:
    """Cumulative sums along the last axis with a leading 0."""
    return np.concatenate([np.zeros(x.shape[:-1] + (1,)), np.cumsum(x, axis=-1)], axis=-1)


def window_correlations(t: Terms) -> np.ndarray:
    """Return each scanned window's largest correlation with an earlier neighbour.

    Windows are taken pattern by pattern, run length by run length, start by start; a
    window's earlier neighbours are the same run one station earlier, the next shorter run
    from the same station and the same run in each earlier pattern. Under the null the
    windows' sums ``A`` have covariance ``sum_i bx_kl,i`` over the shared stations plus the
    common offsets ``tau_ov^2 C C' + tau_s^2 C_g C_g'``.

    Returns
    -------
    ndarray
        One correlation per window the scan tests (``B > 0``); nan for a window with no
        earlier neighbour (a root of the forest).
    """
    P, N = t.a.shape
    cbx, cc, ccg = _cum(t.bx), _cum(t.c), _cum(t.c * t.g_m)
    out = []
    lengths = [L for L in WINDOW_LENGTHS if L <= N]

    for k in range(P):
        for j, L in enumerate(lengths):
            i = np.arange(N - L + 1)

            def win(m, i=i, L=L):
                B = cbx[m, m, i + L] - cbx[m, m, i]
                C, Cg = cc[m, i + L] - cc[m, i], ccg[m, i + L] - ccg[m, i]
                return B, C, Cg, B + t.tau_ov2 * C**2 + t.tau_s2 * Cg**2

            B, C, Cg, var = win(k)
            best = np.full(i.size, -np.inf)
            # the same run one station earlier: stations i .. i + L - 2 shared
            if i.size > 1:
                j0, j1 = i[1:], i[1:] + L - 1
                Cp, Cgp, varp = C[:-1], Cg[:-1], var[:-1]
                cov = (cbx[k, k, j1] - cbx[k, k, j0] + t.tau_ov2 * C[1:] * Cp
                       + t.tau_s2 * Cg[1:] * Cgp)
                r = cov / np.sqrt(np.maximum(var[1:] * varp, 1e-300))
                best[1:] = np.where(B[:-1] > 0, r, -np.inf)
            # the next shorter run from the same station: its stations all shared
            if j:
                Ls = lengths[j - 1]
                Bs = cbx[k, k, i + Ls] - cbx[k, k, i]
                Cs, Cgs = cc[k, i + Ls] - cc[k, i], ccg[k, i + Ls] - ccg[k, i]
                vs = Bs + t.tau_ov2 * Cs**2 + t.tau_s2 * Cgs**2
                cov = Bs + t.tau_ov2 * C * Cs + t.tau_s2 * Cg * Cgs
                r = cov / np.sqrt(np.maximum(var * vs, 1e-300))
                best = np.maximum(best, np.where(Bs > 0, r, -np.inf))
            # the same run in an earlier pattern
            for m in range(k):
                Bm, Cm, Cgm, vm = win(m)
                cov = cbx[k, m, i + L] - cbx[k, m, i] + t.tau_ov2 * C * Cm + t.tau_s2 * Cg * Cgm
                r = cov / np.sqrt(np.maximum(var * vm, 1e-300))
                best = np.maximum(best, np.where(Bm > 0, r, -np.inf))
            best = np.where(np.isfinite(best), np.clip(best, -1.0, 1.0), np.nan)
            out.append(best[B > 0])
    return np.concatenate(out) if out else np.zeros(0)


def hunter_tail(u: float, r: np.ndarray) -> float:
    """Hunter's bound on P(max z > u) for windows with parent correlations ``r`` (nan: root).

    ``sum_roots Q(u) + sum_pairs 2 T_Owen(u, sqrt((1 - r) / (1 + r)))`` (module docstring).
    """
    root = np.isnan(r)
    rr = np.clip(r[~root], -1.0 + 1e-12, 1.0)
    return float(root.sum() * ndtr(-u) + 2 * owens_t(u, np.sqrt((1 - rr) / (1 + rr))).sum())


def critical_z(t: Terms, false_alarm: float) -> float:
    """Return the scan's bound: u where ``hunter_tail`` reaches ``false_alarm`` (module docstring).

    Never above Bonferroni's ``bonferroni_z`` over the windows tested.
    """
    r = window_correlations(t)
    if not r.size:
        return float(ndtri(1.0 - false_alarm))
    top = float(ndtri(1.0 - false_alarm / r.size))
    if hunter_tail(top, r) <= false_alarm * (1 + 1e-9) and hunter_tail(1.0, r) > false_alarm:
        return float(brentq(lambda u: hunter_tail(u, r) - false_alarm, 1.0, top, xtol=1e-4))
    return top


def _window_z(t: Terms, used: np.ndarray) -> tuple[float, int, int, int]:
    """Return the largest z of any window avoiding ``used`` stations: (z, pattern, i0, i1)."""
    cs = [np.concatenate([np.zeros((t.a.shape[0], 1)), np.cumsum(x, axis=1)], axis=1)
          for x in (t.a, t.b, t.c, t.c * t.g_m)]
    cu = np.concatenate([[0], np.cumsum(used)])
    best = (-np.inf, 0, 0, 0)
    N = t.a.shape[1]
    for L in (L for L in WINDOW_LENGTHS if L <= N):
        A, B, C, Cg = (x[:, L:] - x[:, :-L] for x in cs)
        free = (cu[L:] - cu[:-L]) == 0
        var = B + t.tau_ov2 * C**2 + t.tau_s2 * Cg**2
        z = t.normal_z(A / np.sqrt(np.where(var > 0, var, 1.0)), np.arange(A.shape[0])[:, None])
        z = np.where(free & (B > 0), z, -np.inf)
        k, i = np.unravel_index(np.argmax(z), z.shape)
        if z[k, i] > best[0]:
            best = (float(z[k, i]), int(k), int(i), int(i + L))
    return best


def local_z(t: Terms, k: int, i0: int, i1: int) -> float:
    """Return ``A / sqrt(B)``: the run's statistic without the common offsets.

    The systematic offsets are common inside and outside a run, so they say nothing of where
    it ends: its ends are placed by this (the scan statistic of a change-point fit).
    """
    B = t.b[k, i0:i1].sum()
    return float(t.a[k, i0:i1].sum() / np.sqrt(B)) if B > 0 else 0.0


def _refine(t: Terms, k: int, i0: int, i1: int, used: np.ndarray) -> tuple[int, int]:
    """Place a run's ends where ``local_z`` is largest, one end at a time, twice.

    Each end is searched over every station it can reach without crossing a used station
    (the whole stretch: a hill climb a station at a time stops at the first noisy station).
    """
    N = t.a.shape[1]
    ca = np.concatenate([[0.0], np.cumsum(t.a[k])])
    cb = np.concatenate([[0.0], np.cumsum(t.b[k])])
    taken = np.flatnonzero(used)
    lo = int(taken[taken < i0].max() + 1) if (taken < i0).any() else 0
    hi = int(taken[taken >= i1].min()) if (taken >= i1).any() else N

    def z(j0, j1):
        B = cb[j1] - cb[j0]
        return np.where(B > 0, (ca[j1] - ca[j0]) / np.sqrt(np.where(B > 0, B, 1.0)), -np.inf)

    for _ in range(2):
        ends = np.arange(i0 + 1, hi + 1)
        i1 = int(ends[np.argmax(z(i0, ends))])
        starts = np.arange(lo, i1)
        i0 = int(starts[np.argmax(z(starts, i1))])
    return i0, i1


def find_runs(t: Terms, z_crit: float) -> tuple[list[Run], float]:
    """Take the significant runs greedily (module docstring).

    Returns
    -------
    runs : list of Run
        The runs whose z exceeds ``z_crit``, largest first, not overlapping.
    z_max : float
        The largest statistic of the scan (the first run's, or the largest below the bound).
    """
    used = np.zeros(t.a.shape[1], dtype=bool)
    runs: list[Run] = []
    z_max = -np.inf
    while not used.all():
        z, k, i0, i1 = _window_z(t, used)
        z_max = max(z_max, z)
        if not z > z_crit:
            break
        i0, i1 = _refine(t, k, i0, i1, used)
        zr, h, sd = window_stats(t, k, i0, i1)
        runs.append(Run(k, i0, i1, zr, h, sd))
        used[i0:i1] = True
    return runs, float(z_max)
