"""A flat read from the change of the two bending planes' split (issue 38, ../docs/inspection.md).

Wood's shear modulus differs between its radial and tangential planes, so each bending mode
is a pair split by 0.3 % (mode 1) to ~6 % (mode 6) (``updating.correlate.planes``). Between
the baseline and the re-test, moisture and temperature move both members nearly together; a
flat moves the member bending about the flat's normal more. The change of a resolved pair's
split,

    d_k = ln(f_u / f_l)_retest - ln(f_u / f_l)_baseline     (u, l: the upper, lower member),

is a differential measurement that cancels most drift. To first order (Fox and Kapoor; the
mass change of a flat is the same in both planes and cancels)

    d_k = cos(2 phi) P_k(h, x0, x1) - s_u,k u_u + s_l,k u_l + e_k,
    P_k = 1/2 sum_e (U_ke - T_ke) (I_n - I_p)_e / I_0,e,    s_k = 1/2 sum_e V_ke,

with U_ke, V_ke the bending and shear strain-energy fractions of mode k in element e (s_u
with the upper member's plane's E/G, the reference's; s_l with the lower's) and
T_ke its rotary kinetic-energy fraction (EI and rho I both scale with the plane's second
moment; the bat's Timoshenko model from the calibrated reference), I_n, I_p the flat's second
moments bending towards and along the flat (``updating.model.local_change.flat_section``),
phi the flat's normal from the upper member's plane (the radial plane where G_LR > G_LT, as
in ash and maple), u_u, u_l the changes of ln(E/G) of the two planes between the tests, and
e_k the fits' noise (their sd and ``REMOUNT_REL``; ``MODEL_REL`` for the model's error).
Null H0: no flat, |u_u|, |u_l| <= ``RATIO_DRIFT`` (what moisture and temperature do to the
two planes' shear moduli relative to E, which need not move together; stated, not measured
on real bats). H1: a flat over [x0, x1] on a 1 in grid, 2-16 in long, with the amplitude
a = cos(2 phi) P(h) / P(h_ref) free. Per region a weighted least-squares fit (u bounded);
the statistic

    Delta chi^2 = chi^2_0 - min_regions chi^2_1,
    p = min(1, N_regions * P(chi^2_1 > Delta chi^2))       (Bonferroni over the regions),

significant when p < ``LEVEL`` (1e-3, family-wise) and the flat explains the change
(P(chi^2_{n-3} > chi^2_1) >= ``LEVEL``). What the splits can read: the region, the sign of
cos(2 phi) (the normal nearer the upper or the lower member's plane, phi mod 90 deg), and
the depth the flat would have with its normal in a grain plane, a lower bound of its depth
(|cos 2 phi| <= 1). A flat whose normal lies near 45 deg to the grain planes changes both
members alike and is invisible here: not evidence of a clean barrel.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import lsq_linear

from updating.correlate.measured import MeasuredModes
from updating.model.assembly import BatModel, build_model
from updating.model.local_change import flat_section
from updating.model.modes import model_modes
from updating.model.profile import Profile
from updating.model.reference import BatReference
from updating.model.units import IN_TO_M
from updating.tails import chi2_isf, chi2_sf

LEVEL = 1e-3
"""Family-wise significance level of the flat from the splits."""
RATIO_DRIFT = 0.03
"""|u_u|, |u_l|: each plane's E/G may move by this much (relative) between the tests of an
unaltered bat, the two independently (a stated allowance)."""
LOWER_EG_RATIO = 1.3
"""The lower member's plane's E/G over the reference's when diagnose did not resolve it (ash
and maple: E/G_LT / E/G_LR about 1.1-1.6)."""
REMOUNT_REL = 2e-5
"""Per pair, the split's change a re-mounted accelerometer and another tap angle may leave
(the fit's bias from the other member's tail), relative."""
MODEL_REL = 0.1
"""The first-order patterns' error, relative (to the two-plane model within 10 % per mode; the
reference's calibration error, the wood's field): added to a pair's sd, in the test as this
share of the drift H0 reads, in the reading (region, depth, whether a flat fits) of the whole
change."""
FIT_REL_SD = 1e-4
"""A member's relative frequency uncertainty when the fit gave none."""
MAX_REL_DF = 0.03
"""A pair of the re-test is the baseline's pair this close in frequency."""
MIN_PAIRS = 4
"""Pairs needed to tell a flat from the planes' E/G drift (three parameters)."""
GRID_IN = 1.0
MIN_LENGTH_IN, MAX_LENGTH_IN = 2.0, 16.0
H_REF_M = 0.05 * IN_TO_M
"""The depth the regions' patterns are computed at, m."""
LOCALISED_IN = 1.5
"""The region is localised when its centre is known within this, in."""
MESH_M = 0.5 * IN_TO_M
_DEPTHS_M = np.linspace(0.005, 0.25, 50) * IN_TO_M
WHAT_WOULD = ("tap at 45 deg to the grain so both members of each pair show, a longer "
              "record for finer frequency resolution, or the re-test's caliper profile (more "
              "orientations, a finer station spacing)")


@dataclass(frozen=True)
class SplitPair:
    """One resolved pair in both tests: its members (lower, upper), Hz, and its split change."""

    baseline_hz: tuple[float, float]
    retest_hz: tuple[float, float]
    change: float
    sd: float


@dataclass(frozen=True)
class PlaneSplit:
    """The flat the splits read, or why they cannot tell (module docstring), SI.

    Attributes
    ----------
    pairs : tuple of SplitPair
        The pairs resolved in both tests.
    statistic : float
        Delta chi^2 of the best region (NaN: no test).
    p_value : float
        Family-wise p (Bonferroni over ``n_regions``); NaN without a test.
    critical : float
        Delta chi^2 at which p = ``LEVEL``.
    significant : bool
        A flat read: p < ``LEVEL`` and the flat explains the change.
    fits : bool
        The best flat explains the splits' change (chi^2_1 against chi^2_{n-3}).
    ratio_drift : tuple of float
        H0's fitted changes of ln(E/G) of the upper and the lower member's plane.
    region_m : tuple of float or None
        The best region (start, end) from the knob end when significant.
    centre_m : float
        The middle of the centres of the regions within Delta chi^2 = max(1, chi^2_1 /
        (n - 3)) of the best (the scale factor widens it when the best flat fits worse than
        the noise says: model error).
    region_centre_sd_m : float
        Half their spread (at least the grid's 1 in / sqrt 12).
    localised : bool
        The centre is known within ``LOCALISED_IN``.
    depth_m, depth_sd_m : float
        The depth with the normal in a grain plane (a lower bound of the depth) and its sd.
    nearer_plane : str
        "upper" or "lower": the member's plane the normal is nearer to ("" when no flat).
    detectable_depth_m : float
        The shallowest flat (normal in a grain plane, 4-14 in of the barrel) the test reads
        at ``LEVEL`` on average (NaN: none up to 0.25 in).
    notes : tuple of str
        What the splits cannot tell and what would.
    """

    pairs: tuple[SplitPair, ...]
    statistic: float = float("nan")
    p_value: float = float("nan")
    critical: float = float("nan")
    significant: bool = False
    fits: bool = True
    ratio_drift: tuple[float, float] = (0.0, 0.0)
    region_m: tuple[float, float] | None = None
    centre_m: float = float("nan")
    region_centre_sd_m: float = float("nan")
    localised: bool = False
    depth_m: float = float("nan")
    depth_sd_m: float = float("nan")
    nearer_plane: str = ""
    detectable_depth_m: float = float("nan")
    notes: tuple[str, ...] = ()

    def to_json_dict(self) -> dict:
        """Write the reading as a JSON-able dict (SI; NaN left to the writer)."""
        return {"pairs": [{"baseline_hz": list(p.baseline_hz), "retest_hz": list(p.retest_hz),
                           "change": p.change, "sd": p.sd} for p in self.pairs],
                "statistic": self.statistic, "p_value": self.p_value,
                "critical": self.critical, "level": LEVEL, "significant": self.significant,
                "fits": self.fits, "ratio_drift": list(self.ratio_drift),
                "region_m": None if self.region_m is None else list(self.region_m),
                "centre_m": self.centre_m, "region_centre_sd_m": self.region_centre_sd_m,
                "localised": self.localised,
                "depth_m": self.depth_m, "depth_sd_m": self.depth_sd_m,
                "nearer_plane": self.nearer_plane,
                "detectable_depth_m": self.detectable_depth_m, "notes": list(self.notes)}


def _rel_sd(std: np.ndarray | None, k: int, f: np.ndarray) -> np.ndarray:
    if std is None:
        return np.full(2, FIT_REL_SD)
    s = np.asarray(std, float)[k] / f
    return np.where(np.isfinite(s), s, FIT_REL_SD)


def split_pairs(baseline: MeasuredModes, retest: MeasuredModes) -> tuple[SplitPair, ...]:
    """Pair the resolved pairs of both tests and return their split changes d_k and sd.

    A baseline pair takes the re-test pair nearest in mean frequency within ``MAX_REL_DF``;
    sd^2 = the four members' relative variances (the fits' sd, ``FIT_REL_SD`` when none)
    + ``REMOUNT_REL``^2.
    """
    if baseline.plane_pair_hz is None or retest.plane_pair_hz is None:
        return ()
    pb, pr = np.asarray(baseline.plane_pair_hz, float), np.asarray(retest.plane_pair_hz, float)
    ok_b = np.flatnonzero(np.all(np.isfinite(pb), axis=1))
    ok_r = list(np.flatnonzero(np.all(np.isfinite(pr), axis=1)))
    out = []
    for k in ok_b:
        if not ok_r:
            break
        fb = pb[k].mean()
        j = min(ok_r, key=lambda i: abs(pr[i].mean() / fb - 1))
        if abs(pr[j].mean() / fb - 1) > MAX_REL_DF:
            continue
        ok_r.remove(j)
        d = float(np.log(pr[j, 1] / pr[j, 0]) - np.log(pb[k, 1] / pb[k, 0]))
        var = (np.sum(_rel_sd(baseline.plane_pair_std_hz, k, pb[k]) ** 2)
               + np.sum(_rel_sd(retest.plane_pair_std_hz, j, pr[j]) ** 2) + REMOUNT_REL**2)
        out.append(SplitPair((float(pb[k, 0]), float(pb[k, 1])),
                             (float(pr[j, 0]), float(pr[j, 1])), d, float(np.sqrt(var))))
    return tuple(out)


@dataclass(frozen=True)
class SplitModel:
    """Per pair and quadrature sample, what a flat and the planes' drift do to the split.

    ``g`` (n, P): 1/2 (U_ke - T_ke) w_s / L_e per sample s (times (I_n - I_p)/I_0 it gives P_k);
    ``S`` (n, 2): the split's change per unit change of ln(E/G) of the upper and of the lower
    member's plane (-1/2 and +1/2 their shear energy fractions); ``x_m``, ``radius_m`` (P,):
    the samples.
    """

    g: np.ndarray
    S: np.ndarray
    x_m: np.ndarray
    radius_m: np.ndarray
    length_m: float


def _energy_fractions(model: BatModel, shapes: np.ndarray, lam: np.ndarray, part: np.ndarray
                      ) -> np.ndarray:
    """(n, e) phi_e^T k_e phi_e / lambda of each mode in each element."""
    v = shapes[model.dofs]  # (e, 4, n)
    return np.einsum("ain,aij,ajn->na", v, part, v) / lam[:, None]


def split_model(profile: Profile, reference: BatReference, pair_hz: np.ndarray
                ) -> tuple[SplitModel, np.ndarray]:
    """Build the split's sensitivities for pairs at ``pair_hz`` (their mean frequency).

    The reference's wood on a Timoshenko model (0.5 in mesh, its attachments) is the upper
    member's plane; the lower member's has E/G ``e_over_g_plane2`` when diagnose resolved it,
    else ``LOWER_EG_RATIO`` times the reference's. Each pair takes the elastic mode nearest
    in frequency. Returns the model and each pair's mode's relative frequency offset (a pair
    more than 10 % from any mode is not the model's).
    """
    material = reference.material()
    eg_lower = reference.e_over_g_plane2 or LOWER_EG_RATIO * material.e_over_g
    shear, smp = [], None
    for eg in (material.e_over_g, max(eg_lower, material.e_over_g)):
        model = build_model(profile, replace(material, e_over_g=eg), beam="timoshenko",
                            element_length_m=MESH_M,
                            attachments=reference.attachments(profile.length_m))
        modes = model_modes(model, n_modes=len(pair_hz) + 6)
        elastic = np.flatnonzero(modes.freq_hz >= 20.0)
        idx = [int(elastic[np.argmin(np.abs(modes.freq_hz[elastic] - f))]) for f in pair_hz]
        lam, shapes = modes.omega2[idx], modes.shapes[:, idx]
        shear.append(0.5 * _energy_fractions(model, shapes, lam, model.parts.k_shear).sum(1))
        if smp is None:
            offset = np.asarray(modes.freq_hz)[idx] / np.asarray(pair_hz) - 1
            ub = _energy_fractions(model, shapes, lam, model.parts.k_bend)
            tr = _energy_fractions(model, shapes, np.ones_like(lam), model.parts.m_rot)
            smp, L = model.samples, model.element_length_m
            g = 0.5 * (ub - tr)[:, smp.elem] * (smp.weight_m / L[smp.elem])[None, :]
    radius = 0.5 * profile.diameter_at(smp.x_m)
    S = np.column_stack([-shear[0], shear[1]])
    return SplitModel(g, S, smp.x_m, radius, profile.length_m), offset


def flat_weight(radius_m: np.ndarray, depth_m: float) -> np.ndarray:
    """(I_n - I_p) / (pi R^4 / 4) of a flat ``depth_m`` deep (negative: I_n drops more)."""
    _, i_n, i_p = flat_section(radius_m, depth_m)
    return (i_n - i_p) / (np.pi * radius_m**4 / 4)


def _regions(length_m: float) -> np.ndarray:
    """(N, 2) the grid's regions: ends on a 1 in grid (and the barrel end), 2-16 in long."""
    L_in = length_m / IN_TO_M
    ends = np.append(np.arange(0.0, L_in, GRID_IN), L_in)
    out = [(a, b) for i, a in enumerate(ends) for b in ends[i + 1:]
           if MIN_LENGTH_IN - 1e-9 <= b - a <= MAX_LENGTH_IN + 1e-9]
    return np.array(out) * IN_TO_M


def _patterns(m: SplitModel, regions: np.ndarray, depth_m: float) -> np.ndarray:
    """(N, n) P_k of a flat ``depth_m`` deep at phi = 0 over each region."""
    w = m.g * flat_weight(m.radius_m, depth_m)[None, :]  # (n, P)
    inside = (m.x_m[None, :] > regions[:, :1]) & (m.x_m[None, :] < regions[:, 1:])
    return inside.astype(float) @ w.T


def _bounded_fit(A: np.ndarray, d: np.ndarray, n_free: int) -> tuple[float, np.ndarray]:
    """(chi^2, x) of d ~ A x, the first ``n_free`` free, the rest within +-RATIO_DRIFT."""
    lo = np.r_[np.full(n_free, -np.inf), np.full(A.shape[1] - n_free, -RATIO_DRIFT)]
    x = lsq_linear(A, d, bounds=(lo, -lo)).x
    return float(np.sum((d - A @ x) ** 2)), x


def _flat_fits(d: np.ndarray, S: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return (chi^2_1, a) per region of the whitened splits: a P + S u, |u| <= RATIO_DRIFT.

    The unbounded fit for every region at once (S projected out); where it leaves u outside
    the bounds, the bounded one on the bounds' edges (``_edge_fits``), every region at once.
    """
    Q, _ = np.linalg.qr(S)
    d_perp, P_perp = d - Q @ (Q.T @ d), P - (P @ Q) @ Q.T
    norm = np.sum(P_perp**2, axis=1)
    ok = norm > 1e-12 * max(norm.max(), 1e-300)
    amp = np.where(ok, P_perp @ d_perp / np.where(ok, norm, 1.0), 0.0)
    u = np.linalg.lstsq(S, (d[None, :] - amp[:, None] * P).T, rcond=None)[0].T
    chi = np.sum((d[None, :] - amp[:, None] * P - u @ S.T) ** 2, axis=1)
    chi[~ok] = np.inf
    out = np.flatnonzero(ok & np.any(np.abs(u) > RATIO_DRIFT, axis=1))
    chi[out], amp[out] = _edge_fits(d, S, P[out], RATIO_DRIFT)
    return chi, amp


def _edge_fits(d: np.ndarray, S: np.ndarray, P: np.ndarray,
               bound: float) -> tuple[np.ndarray, np.ndarray]:
    """(chi^2, a) per row of P of d ~ a P + S u, a free, u on the edge of |u_j| <= bound.

    Where the fit without bounds leaves u outside the square, the bounded fit, a convex
    quadratic in u once a is eliminated (d and S projected off the row's pattern p:
    R = I - p p^T / |p|^2), has its minimum on the square's edge: on each side the other
    coordinate's one-dimensional least squares clipped to the side (the corners included).
    The least of the four sides, every row at once; exact, as ``lsq_linear`` is to its
    tolerance. S has the two planes' columns.

    Parameters
    ----------
    d : numpy.ndarray
        (n,) the whitened changes of the splits.
    S : numpy.ndarray
        (n, 2) the two planes' drift patterns.
    P : numpy.ndarray
        (N, n) the flats' patterns, none of them zero.
    bound : float
        The bound on |u_j| (``RATIO_DRIFT``).

    Returns
    -------
    chi2, amplitude : numpy.ndarray
        (N,) each.
    """
    def off_p(v: np.ndarray) -> np.ndarray:  # (N, n): v projected off each row's pattern
        return v[None, :] - P * ((P @ v) / pp)[:, None]

    pp = np.sum(P**2, axis=1)
    Rd, RS = off_p(d), [off_p(S[:, j]) for j in range(2)]
    best_chi = np.full(P.shape[0], np.inf)
    best_u = np.zeros((P.shape[0], 2))
    for j, side in ((0, -bound), (0, bound), (1, -bound), (1, bound)):
        k = 1 - j
        rest = Rd - side * RS[j]
        norm = np.sum(RS[k] ** 2, axis=1)
        uk = np.clip(np.sum(RS[k] * rest, axis=1) / np.where(norm > 0, norm, 1.0),
                     -bound, bound)
        chi = np.sum((rest - uk[:, None] * RS[k]) ** 2, axis=1)
        better = chi < best_chi
        best_chi[better] = chi[better]
        best_u[better, j], best_u[better, k] = side, uk[better]
    return best_chi, (P @ d - np.sum(P * (best_u @ S.T), axis=1)) / pp


def _noncentrality(P: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Per region, Delta chi^2 a flat's pattern P gives without noise (S projected out)."""
    Q, _ = np.linalg.qr(S)
    P = P - (P @ Q) @ Q.T
    return np.sum(P**2, axis=1)


def read_plane_split(profile: Profile, reference: BatReference, baseline: MeasuredModes,
                     retest: MeasuredModes) -> PlaneSplit:
    """Read a flat from the change of the resolved pairs' splits (module docstring).

    Parameters
    ----------
    profile : Profile
        The bat's outer profile.
    reference : BatReference
        Its reference calibrated to the baseline (the wood and the attachments).
    baseline, retest : MeasuredModes
        The two tests' fitted modes with their merged pairs' members (``plane_pair_hz``).

    Returns
    -------
    PlaneSplit
        The reading, or what the splits cannot tell and what would.
    """
    pairs = split_pairs(baseline, retest)
    if len(pairs) < MIN_PAIRS:
        return PlaneSplit(pairs, notes=(
            f"a flat is not measurable from the bending planes' splits by this test: "
            f"{len(pairs)} pair{'s' if len(pairs) != 1 else ''} resolved in both tests, "
            f"{MIN_PAIRS} needed to tell a flat from the planes' own drift; what would: "
            f"{WHAT_WOULD}",))
    m, offset = split_model(profile, reference,
                            np.array([np.mean(p.baseline_hz) for p in pairs]))
    keep = np.abs(offset) < 0.1
    if keep.sum() < MIN_PAIRS:
        return PlaneSplit(pairs, notes=(
            "a flat is not measurable from the bending planes' splits: the resolved pairs "
            "are not the reference's modes; what would: " + WHAT_WOULD,))
    change = np.array([p.change for p in pairs])[keep]
    meas = np.array([p.sd for p in pairs])[keep]
    m = SplitModel(m.g[keep], m.S[keep], m.x_m, m.radius_m, m.length_m)
    # the test: the fits' noise and MODEL_REL of the drift H0 reads (its pattern's error)
    d, w = _whiten(m, change, meas)
    _, u = _bounded_fit(w.S, d, 0)
    d, w = _whiten(m, change, np.hypot(meas, MODEL_REL * (m.S @ u)))
    regions = _regions(m.length_m)
    chi0, u0 = _bounded_fit(w.S, d, 0)
    chi1, _ = _flat_fits(d, w.S, _patterns(w, regions, H_REF_M))
    stat = max(chi0 - float(chi1.min()), 0.0)
    n_reg = len(regions)
    p = min(1.0, n_reg * chi2_sf(stat, 1))
    critical = chi2_isf(LEVEL / n_reg, 1)
    detect = _detectable_depth(w, regions, critical)
    # the reading: MODEL_REL of the whole change (the flat's pattern's error too)
    d, w = _whiten(m, change, np.hypot(meas, MODEL_REL * change))
    P = _patterns(w, regions, H_REF_M)
    chi1, amp = _flat_fits(d, w.S, P)
    best = int(np.argmin(chi1))
    fits = bool(chi2_sf(chi1[best], max(len(d) - 3, 1)) >= LEVEL)
    common = dict(statistic=float(stat), p_value=p, critical=critical, fits=fits,
                  ratio_drift=(float(u0[0]), float(u0[1])), detectable_depth_m=detect)
    if p >= LEVEL or not fits:
        return PlaneSplit(pairs, significant=False, notes=_cannot_tell(stat, critical, fits,
                                                                       detect), **common)
    scale = max(1.0, chi1[best] / max(len(d) - 3, 1))
    centres = regions[chi1 <= chi1[best] + scale].mean(axis=1)
    half = max(0.5 * (centres.max() - centres.min()), GRID_IN * IN_TO_M / np.sqrt(12))
    depth, depth_sd = _depth(w, regions[best], amp[best], P[best])
    return PlaneSplit(pairs, significant=True,
                      region_m=(float(regions[best, 0]), float(regions[best, 1])),
                      centre_m=float(0.5 * (centres.max() + centres.min())),
                      region_centre_sd_m=float(half), localised=half <= LOCALISED_IN * IN_TO_M,
                      depth_m=depth, depth_sd_m=depth_sd,
                      nearer_plane="upper" if amp[best] > 0 else "lower", **common)


def _whiten(m: SplitModel, change: np.ndarray, sd: np.ndarray
            ) -> tuple[np.ndarray, SplitModel]:
    """Return the changes and the model divided by the pairs' sd."""
    return change / sd, SplitModel(m.g / sd[:, None], m.S / sd[:, None], m.x_m, m.radius_m,
                                   m.length_m)


def _depth(m: SplitModel, region: np.ndarray, a: float, p_ref: np.ndarray
           ) -> tuple[float, float]:
    """Return the grain-plane depth whose pattern has amplitude |a| of the reference's, and its sd.

    q(h) = P(h).P_ref / P_ref.P_ref is monotone in h; sd of a from the fit (a P + S u),
    carried through dq/dh.
    """
    q = np.array([_patterns(m, region[None, :], h)[0] @ p_ref for h in _DEPTHS_M]) / (
        p_ref @ p_ref)
    h = float(np.interp(abs(a), q, _DEPTHS_M))
    A = np.column_stack([p_ref, m.S])
    cov = np.linalg.pinv(A.T @ A)
    a_sd = float(np.sqrt(cov[0, 0]))
    slope = float(np.interp(h, _DEPTHS_M, np.gradient(q, _DEPTHS_M)))
    return h, a_sd / slope if slope > 0 else float("nan")


def _detectable_depth(m: SplitModel, regions: np.ndarray, critical: float) -> float:
    """Return the shallowest grain-plane flat over 4-14 in of the barrel read at the level.

    The median over such regions of the noise-free Delta chi^2 must reach the critical value
    (about half of such flats read).
    """
    L = m.length_m
    span = regions[:, 1] - regions[:, 0]
    barrel = regions[(regions[:, 1] >= L - 2 * IN_TO_M) & (span >= 4 * IN_TO_M - 1e-9)
                     & (span <= 14 * IN_TO_M + 1e-9)]
    for h in _DEPTHS_M:
        if np.median(_noncentrality(_patterns(m, barrel, h), m.S)) >= critical:
            return float(h)
    return float("nan")


def _cannot_tell(stat: float, critical: float, fits: bool, detect_m: float) -> tuple[str, ...]:
    """Say what the splits could not tell and what would; never evidence of a clean barrel."""
    if not fits:
        return ("the bending planes' splits changed in a way no flat explains (the planes' "
                "members read in another order, or a fit's member off): no flat read from "
                f"them; what would measure one: {WHAT_WOULD}",)
    seen = (f"a flat over 4-14 in of the barrel at least {detect_m / IN_TO_M:.2f} in deep "
            "with its normal near a grain plane" if np.isfinite(detect_m) else
            "no flat up to 0.25 in deep")
    return (f"the bending planes' splits read no flat (Delta chi^2 {stat:.1f} against "
            f"{critical:.1f}); they would read {seen}; a shallower flat, or one whose normal "
            "lies near 45 deg to the grain planes (both members change alike), is not "
            f"measurable by this test and this is not evidence of a clean barrel; what would "
            f"measure it: {WHAT_WOULD}",)
