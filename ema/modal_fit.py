"""Automatic experimental modal analysis of one test: FRFs -> poles -> scaled modes.

``fit_test`` runs, with no human picking (one function per step below; a band reaching past
the data is clipped to it, with a note):

1. poles: polyreference LSCF over an order sweep in overlapping sub-bands (``ema.poles.lscf``,
   ``ema.poles.autopoles``), stabilisation and automatic selection
   (``ema.poles.stabilisation``); stable poles just outside the band (modes the band edge
   cuts) join the LSFD as computational poles (when there is a misfit above 1e-4 and they
   lower it by 5 % or more) but are not reported; or, with ``method="peak"``, sum-MIF
   peaks with half-power damping (``ema.poles.mif``);
2. residues of every FRF with lower and upper residual terms (``ema.shapes.lsfd``);
3. modes without support in the data are dropped: a mode whose contribution at its own
   resonance, RMS over the FRFs, is below ``min_snr`` times the RMS misfit of the synthesis
   around it is noise fitted by the model; the residues are then re-estimated without it;
4. mass-normalised complex shapes from the driving point (``ema.shapes.scaling``), real shapes,
   MPC and MPD (``ema.shapes.complexity``);
   Optionally (``refine=True``) the poles are then refined together by maximum likelihood
   with the residues eliminated (``ema.poles.refine``);
5. exponential-window damping correction zeta = zeta_measured - 1 / (tau w_r);
6. modes below ``suspension_max_hz`` are the suspension's rigid-body modes: reported apart,
   and used for the mass check (``ema.shapes.mass_line``). A band starting below
   ``suspension_max_hz`` fits them as modes and drops the lower residual terms (which would
   trade off against them); otherwise the lower residual is the mass line, re-estimated on
   the band below the second bending mode (``ema.shapes.mass_line.low_band_mass_line``);
7. per-mode warnings (under-resolved damping, leakage, low coherence: ``ema.mode_checks``;
   possibly merged pair: a rejected second pole next to it) and close pairs.

Every candidate pole that is not reported says why (``ModalFit.rejected``,
``ema.poles.rejected``), and a fit that finds nothing says why in ``ModalFit.notes``.
A test without a driving point gives *unscaled* shapes (largest entry 1, ``scaled`` False):
the mass normalisation needs the driving-point residue.

Orientation: the polyreference "references" are the side with fewer nodes. For a roving-hammer
test (1 accelerometer x n impacts) the FRF matrix is fitted transposed (reciprocity,
H_jk = H_kj): n outputs (the impact nodes), one reference. The shapes are given at the nodes of
the longer side (the impact nodes for a roving hammer), from the FRFs sharing the driving
point's node on the shorter side.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema.io.frf_data import FrfTest
from ema.mode_checks import CLOSE_PAIR, ClosePair, close_pairs, mode_warnings
from ema.poles.autopoles import auto_poles, overlapping
from ema.poles.local_support import (
    MAX_SHIFT,
    MIN_LINES,
    MIN_MPC,
    line_weight,
    local_support,
)
from ema.poles.lscf import PoleSweep
from ema.poles.mif import PeakPick, pick_peaks, receptance_power, sum_mif
from ema.poles.refine import refine_poles
from ema.poles.rejected import Rejection
from ema.poles.stabilisation import Stability
from ema.shapes.complexity import mpc, mpd, real_modes
from ema.shapes.lsfd import QUANTITY_POWER, LsfdResult, lsfd
from ema.shapes.mass_line import (
    RigidBody,
    low_band_mass_line,
    rigid_body_from_mass_line,
    rigid_body_from_modes,
)
from ema.shapes.noise import shape_noise_from_coherence
from ema.shapes.scaling import fix_sign, mass_normalised_shapes, unscaled_shapes

METHODS = ("lscf", "peak")
MIN_SNR = 10.0
MIN_POINTS = 3  # FRFs a second look needs: with fewer, a shape's phase spread says nothing
PEAK_SHARE = 0.75  # of the support threshold that a rescued mode's highest line needs
MIN_GLOBAL_SNR = 1.0  # below: the band fit does not see the mode; no second look at its peak


@dataclass(frozen=True)
class ModalFit:
    """Modes of one test, ascending in frequency.

    Attributes
    ----------
    freq_hz
        (m,) undamped natural frequencies |lambda| / 2 pi, Hz.
    damping_ratio
        (m,) viscous damping ratios (exponential window removed).
    shapes
        (n_nodes, m) complex mass-normalised shapes, 1/sqrt(kg) (``ema.shapes.scaling``);
        unscaled (largest entry 1) when the test has no driving point (``scaled`` False).
    real_shapes
        (n_nodes, m) nearest real shapes, 1/sqrt(kg); sign: driving-point entry
        positive (largest-magnitude entry positive when the driving point is a node or
        the test has none).
    nodes
        (n_nodes,) node numbers of the shape rows (the impact nodes for a roving hammer).
    x_m
        (n_nodes,) node positions from the knob end, m.
    driving_index
        row of ``nodes`` that is the driving point (None: no driving point).
    driving_frf
        (response index, reference index) of the driving-point FRF (or None).
    scaled
        True when the shapes are mass-normalised (a driving point was measured).
    mpc
        (m,) modal phase collinearity, 0..1 (1: real mode).
    mpd
        (m,) mean phase deviation, degrees (0: real mode).
    freq_std_hz, damping_std
        (m,) spread over the model orders (NaN for the peak method);
        with ``refine`` the least-squares standard deviations.
    stable_count
        (m,) model orders at which the mode was stable (0 for the peak method).
    synthesis_error
        (n_resp, n_ref) relative misfit ||H - H_synth|| / ||H|| in the band.
    synthesis_error_total
        the same over all FRFs together.
    residue
        (n_resp, n_ref, m) complex residues A_r (receptance pole-residue form).
    mass_line
        (n_resp, n_ref) lower residual L0, 1/kg (the rigid-body flexibility; from
        the band below the second bending mode, ``ema.shapes.mass_line``).
    suspension_freq_hz, suspension_damping_ratio
        modes below ``suspension_max_hz``.
    suspension_shapes
        (n_nodes, s) their real mass-normalised shapes.
    rigid_body
        mass / centre of mass / pitch inertia implied by the scaling.
    window_damping
        (m,) damping removed for the exponential window (0 when none).
    band_hz, method, quantity
        what was fitted.
    band_freq_hz
        (F_band,) lines of the fit; synth: (F_band, n_resp, n_ref) synthesis.
    mif
        (F_band,) sum MIF of the measured FRFs on those lines.
    sweep, stability
        LSCF stabilisation data (None for the peak method).
    peaks
        the sum-MIF peaks (both methods: the quick cross-check).
    rejected
        every candidate pole not reported, with why (``ema.poles.rejected``).
    warnings
        per mode, what its numbers cannot be trusted for (``ema.mode_checks``).
    close_pairs
        neighbouring modes closer than 6.5 % (``ema.mode_checks``).
    notes
        fit-level notes (band clipped, no driving point, why nothing was found).
    decisions
        per mode, why it was kept (its support, ``_support_decisions``).
    shape_noise_rel
        (m,) relative standard deviation of a shape entry per mode from the test's coherence
        and averages (``ema.shapes.noise``); None when the test carries no coherence.
    """

    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    real_shapes: np.ndarray
    nodes: np.ndarray
    x_m: np.ndarray
    driving_index: int | None
    driving_frf: tuple[int, int] | None
    mpc: np.ndarray
    mpd: np.ndarray
    freq_std_hz: np.ndarray
    damping_std: np.ndarray
    stable_count: np.ndarray
    synthesis_error: np.ndarray
    synthesis_error_total: float
    residue: np.ndarray
    mass_line: np.ndarray
    suspension_freq_hz: np.ndarray
    suspension_damping_ratio: np.ndarray
    suspension_shapes: np.ndarray
    rigid_body: RigidBody
    window_damping: np.ndarray
    band_hz: tuple[float, float]
    method: str
    quantity: str
    band_freq_hz: np.ndarray
    synth: np.ndarray
    mif: np.ndarray
    sweep: PoleSweep | None
    stability: Stability | None
    peaks: PeakPick
    scaled: bool = True
    rejected: tuple[Rejection, ...] = ()
    warnings: tuple[tuple[str, ...], ...] = ()
    close_pairs: tuple[ClosePair, ...] = ()
    notes: tuple[str, ...] = ()
    decisions: tuple[str, ...] = ()
    shape_noise_rel: np.ndarray | None = None


@dataclass(frozen=True)
class _Layout:
    """Polyreference orientation (module docstring).

    The FRFs as fitted, the shape nodes, the driving point (None when the test has none) and
    the residue row the shapes come from.
    """

    h_poly: np.ndarray
    nodes: np.ndarray
    row_layout: bool
    driving: tuple[int, int] | None
    d_index: int | None


@dataclass(frozen=True)
class _Poles:
    """Poles to fit residues to (step 1) and their uncertainties."""

    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    freq_std_hz: np.ndarray
    damping_std: np.ndarray
    count: np.ndarray
    extra: np.ndarray
    sweep: PoleSweep | None
    stability: Stability | None
    rejected: list[Rejection]
    why: tuple[str, ...] = ()

    @property
    def pole(self) -> np.ndarray:
        return _poles(self.damping_ratio, self.freq_hz)


def default_band(freq_hz: np.ndarray, low_hz: float = 20.0) -> tuple[float, float]:
    """Return the default band: from max(low_hz, first nonzero line) to the last line.

    Parameters
    ----------
    freq_hz : ndarray
        (F,) the test's lines, Hz.
    low_hz : float
        Lowest start, Hz (above the suspension modes).

    Returns
    -------
    tuple of float
        (lo, hi), Hz.
    """
    f = np.asarray(freq_hz, dtype=float)
    return float(max(low_hz, f[f > 0][0])), float(f[-1])


def clip_band(
    freq_hz: np.ndarray, band_hz: tuple[float, float] | None
) -> tuple[tuple[float, float], list[str]]:
    """Return the band to fit and a note when the requested one reached past the data.

    Parameters
    ----------
    freq_hz : ndarray
        (F,) the test's lines, Hz.
    band_hz : tuple of float or None
        (lo, hi) requested, Hz; None: ``default_band``.

    Returns
    -------
    band : tuple of float
        (lo, hi) clipped to the data, Hz.
    notes : list of str
        One note when the band was clipped.

    Raises
    ------
    ValueError
        When the requested band and the data do not overlap.
    """
    f = np.asarray(freq_hz, dtype=float)
    if band_hz is None:
        band = default_band(f)
        if band[0] >= band[1]:
            raise ValueError(f"the data end at {band[1]:g} Hz, below the default band start "
                             f"{band[0]:g} Hz: give --band")
        return band, []
    lo, hi = float(band_hz[0]), float(band_hz[1])
    first, last = float(f[f > 0][0]), float(f[-1])
    if not lo < hi:
        raise ValueError(f"band {lo:g}-{hi:g} Hz is empty")
    if hi <= first or lo >= last:
        raise ValueError(f"band {lo:g}-{hi:g} Hz is not inside the test's {f[0]:g}-{last:g} Hz")
    clipped = (max(lo, first), min(hi, last))
    if clipped != (lo, hi):
        return clipped, [f"band {lo:g}-{hi:g} Hz reaches past the data ({f[0]:g}-{last:g} Hz): "
                         f"clipped to {clipped[0]:g}-{clipped[1]:g} Hz"]
    return clipped, []


def _poles(zeta: np.ndarray, freq_hz: np.ndarray) -> np.ndarray:
    wn = 2 * np.pi * np.asarray(freq_hz, dtype=float)
    z = np.asarray(zeta, dtype=float)
    return -z * wn + 1j * wn * np.sqrt(1 - z**2)


def _misfit(fit: LsfdResult, h: np.ndarray) -> float:
    return float(np.linalg.norm(h - fit.synth))


def _require_usable(h_band: np.ndarray, band: tuple[float, float]) -> None:
    """ValueError when the data cannot hold a mode: too few lines or no signal in the band."""
    if h_band.shape[0] < 8:
        raise ValueError(f"band {band[0]:g}-{band[1]:g} Hz has {h_band.shape[0]} lines "
                         "(too few lines to fit; at least 8)")
    if not np.any(np.abs(h_band) > 0):
        raise ValueError(f"every FRF is zero in {band[0]:g}-{band[1]:g} Hz")


def _layout(test: FrfTest) -> _Layout:
    """Step 0: orientation (fewer nodes = references) and the driving point, if any."""
    n_resp, n_ref = test.frf.shape[1:]
    row_layout = n_ref >= n_resp  # shapes along the references (roving hammer)
    try:
        driving = test.driving_point
    except ValueError:
        driving = None
    return _Layout(
        h_poly=np.transpose(test.frf, (0, 2, 1)) if row_layout else test.frf,
        nodes=np.asarray(test.reference_nodes if row_layout else test.response_nodes),
        row_layout=row_layout,
        driving=driving,
        d_index=None if driving is None else (driving[1] if row_layout else driving[0]),
    )


def _select_poles(
    test: FrfTest, lay: _Layout, band: tuple[float, float], method: str,
    max_order: int | None, peaks: PeakPick,
) -> _Poles:
    """Step 1: poles by LSCF + automatic stabilisation, or the sum-MIF peaks."""
    if method == "lscf":
        n_poly_ref = lay.h_poly.shape[2]
        p_max = int(max_order) if max_order else max(12, 30 // n_poly_ref)
        auto = auto_poles(test.freq_hz, lay.h_poly, band, p_max)
        sel, rejected = auto.modes, list(auto.rejected)
        rescued = _peak_confirmed(sel.freq_hz, sel.damping_ratio, rejected, peaks)
        f_r = np.array([r.freq_hz for r in rescued])
        z_r = np.array([r.damping_ratio for r in rescued])
        order = np.argsort(np.r_[sel.freq_hz, f_r])

        def cat(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            return np.r_[a, b][order]

        return _Poles(cat(sel.freq_hz, f_r), cat(sel.damping_ratio, z_r),
                      cat(sel.freq_std_hz, np.full(f_r.size, np.nan)),
                      cat(sel.damping_std, np.full(f_r.size, np.nan)),
                      cat(sel.count, np.array([r.stable_orders for r in rescued], dtype=int)),
                      np.concatenate([auto.outside.pole, auto.computational]),
                      auto.sweep, auto.stability,
                      [r for r in rejected if r not in rescued])
    n = peaks.freq_hz.size
    return _Poles(peaks.freq_hz, peaks.damping_ratio, np.full(n, np.nan), np.full(n, np.nan),
                  np.zeros(n, dtype=int), np.zeros(0, dtype=complex), None, None, [])


def _merge_warnings(freq_hz: np.ndarray, rejected: list[Rejection]) -> list[list[str]]:
    """Warn, per mode, of a possibly merged pair.

    The warning is given when a second pole within ``CLOSE_PAIR`` of the mode was
    rejected (merged into it, or without support in the data): the fitter saw two poles and
    reports one.
    """
    out: list[list[str]] = []
    for f in freq_hz:
        w = []
        near = [r for r in rejected if r.reason in ("merged", "support")
                and 0 < abs(r.freq_hz / f - 1) < CLOSE_PAIR]
        if near:
            r = min(near, key=lambda r: abs(r.freq_hz - f))
            w.append(f"possibly merged pair: a second pole at {r.freq_hz:.5g} Hz "
                     f"({abs(r.freq_hz / f - 1):.2%} away) was rejected ({r.reason})")
        out.append(w)
    return out


def _peak_confirmed(
    mode_freq_hz: np.ndarray, mode_damping: np.ndarray, rejected: list[Rejection],
    peaks: PeakPick, min_orders: int = 3,
) -> list[Rejection]:
    """Return the candidates rejected for stability that a sum-MIF peak confirms.

    Those stable at >= min_orders
    orders, within the peak's half-power half-width (at least 1 %) of a peak that no selected
    mode explains. A heavily damped mode whose peak moves between the FRFs is stable at fewer
    orders than the automatic criterion asks, yet plain to see; the support check after the
    LSFD still applies to it. One (the most stable) per peak. A candidate inside a selected
    mode's half-power width (``merge_overlapping``'s rule) is not rescued: a peak split in two
    by a null of the hammer's force spectrum shows two sum-MIF peaks around one mode.
    """
    out: list[Rejection] = []
    for fp, zp in zip(peaks.freq_hz, peaks.damping_ratio, strict=True):
        width = max(zp, 0.01) * fp
        if np.any(np.abs(mode_freq_hz - fp) <= width):
            continue
        near = [r for r in rejected if r.reason == "stability" and r.stable_orders >= min_orders
                and abs(r.freq_hz - fp) <= width and r not in out
                and not np.any(overlapping(mode_freq_hz, mode_damping, r.freq_hz,
                                           r.damping_ratio))]
        if near:
            out.append(max(near, key=lambda r: r.stable_orders))
    return out


def _support(
    fit: LsfdResult, h: np.ndarray, poles: np.ndarray, quantity: str
) -> tuple[np.ndarray, np.ndarray]:
    """Return (signal, noise) per mode.

    Its contribution at its own resonance (RMS over the FRFs) and the RMS misfit of the
    synthesis within 5 half-power half-widths (at least 5 lines).
    """
    f = fit.freq_hz
    misfit = np.sqrt(np.mean(np.abs(h - fit.synth) ** 2, axis=1))  # (F,)
    s = 1j * np.abs(poles)  # i w_r
    term = s ** QUANTITY_POWER[quantity] * (
        fit.residue[:, : poles.size] / (s - poles) + np.conj(fit.residue[:, : poles.size])
        / (s - np.conj(poles))
    )  # (n_frf, m): each mode's own contribution at its resonance
    signal = np.sqrt(np.mean(np.abs(term) ** 2, axis=0))
    noise = np.zeros(poles.size)
    for r, lam in enumerate(poles):  # one window per mode
        half_bw = max(-lam.real / (2 * np.pi), f[1] - f[0])
        near = np.abs(f - abs(lam) / (2 * np.pi)) <= 5 * half_bw
        noise[r] = np.sqrt(np.mean(misfit[near] ** 2)) if near.any() else 0.0
    return signal, noise


def support_threshold(damping_ratio: np.ndarray, min_snr: float = MIN_SNR) -> np.ndarray:
    """Return the support a mode needs: min_snr / sqrt(max(1, zeta / 1 %)).

    The local misfit of a heavily damped mode holds more than noise: FRFs whose peak moves
    ~2 % between the points leave a systematic misfit over its wide half-power band that a
    common-pole model cannot remove (at 5 % damping the threshold is 4.5, at 1 % and below
    ``min_snr``).

    Parameters
    ----------
    damping_ratio : ndarray
        (m,) the modes' damping ratios.
    min_snr : float
        The threshold of a lightly damped mode.

    Returns
    -------
    ndarray
        (m,) contribution at resonance over local misfit that each mode needs.
    """
    return min_snr / np.sqrt(np.maximum(1.0, np.asarray(damping_ratio, float) / 0.01))


def _with_extra(
    freq: np.ndarray, h_flat: np.ndarray, sel: np.ndarray, p: _Poles, quantity: str,
    band: tuple[float, float], lower: bool,
) -> tuple[LsfdResult, np.ndarray]:
    """Step 2: LSFD residues, with the computational poles when they lower a real misfit by 5 %.

    Returns the fit and the computational poles used (empty when they did not help).
    """
    fit = lsfd(freq, h_flat, p.pole, quantity, band, lower=lower)
    extra = p.extra
    if extra.size:  # computational poles only when they explain the band edges better
        with_extra = lsfd(freq, h_flat, np.r_[p.pole, extra], quantity, band, lower=lower)
        base = _misfit(fit, h_flat[sel])
        better = _misfit(with_extra, h_flat[sel]) < 0.95 * base
        if better and base > 1e-4 * np.linalg.norm(h_flat[sel]):
            return with_extra, extra
    return fit, extra[:0]


def _support_decisions(
    test: FrfTest, fit: LsfdResult, sel: np.ndarray, p: _Poles, min_snr: float
) -> tuple[np.ndarray, list[str], list[Rejection]]:
    """Step 3: which modes the data support, and why each was kept or dropped.

    A mode is kept when its contribution at resonance stands ``support_threshold`` above the
    misfit of the band's synthesis around it; failing that, when it at least stands above that
    misfit (``MIN_GLOBAL_SNR``: the band fit sees it, but the misfit may not be its own), the
    test has ``MIN_POINTS`` FRFs or more (a shape to judge across the points) and,
    fitted on its own peak (``ema.poles.local_support``: coherence-weighted, pole refined),
    its evidence over its half-power band stands that far above the local misfit and its
    highest line ``PEAK_SHARE`` of that (a peak a person sees, over several lines), its residues
    are collinear in phase (MPC >= ``MIN_MPC``; the local fit also holds the other candidates
    and the poles rejected for stability, so that a neighbour or a force null next to the
    peak is modelled, not counted as misfit), its half-power band spans ``MIN_LINES``
    lines or more, the refined frequency stays within a half-power half-width and is not the
    peak of a mode already kept.

    Returns
    -------
    keep : ndarray
        (m,) bool, the modes kept.
    why : list of str
        For each kept mode, the reason.
    rejected : list of Rejection
        The dropped ones (reason ``support``).
    """
    h_flat = test.frf.reshape(test.freq_hz.size, -1)
    signal, noise = _support(fit, h_flat[sel], p.pole, test.quantity)
    need = support_threshold(p.damping_ratio, min_snr)
    keep = signal > need * noise
    weight = line_weight(test.coherence)
    seen = _poles(*np.array([(r.damping_ratio, r.freq_hz) for r in p.rejected
                             if r.reason == "stability"]).reshape(-1, 2).T)
    why, rejected = [], []
    for r in range(p.freq_hz.size):
        ratio = signal[r] / max(noise[r], 1e-300)
        glob = (f"contribution at resonance {ratio:.3g} x the band fit's misfit "
                f"(needs {need[r]:.3g})")
        if keep[r] or ratio < MIN_GLOBAL_SNR or h_flat.shape[1] < MIN_POINTS:
            if keep[r]:
                why.append(glob)
            else:
                rejected.append(Rejection(float(p.freq_hz[r]), float(p.damping_ratio[r]),
                                          "support", glob))
            continue
        loc = local_support(test.freq_hz, h_flat, test.quantity, float(p.freq_hz[r]),
                            float(p.damping_ratio[r]), np.r_[np.delete(p.pole, r), seen], weight)
        own = (f"on its own peak {loc.snr:.3g} x the local misfit (needs "
               f"{PEAK_SHARE * need[r]:.3g}), {loc.evidence:.3g} over its half-power band "
               f"(needs {need[r]:.3g}), MPC {loc.mpc:.2f}, refined {loc.freq_hz:.5g} Hz")
        kept_hz = p.freq_hz[keep]
        half = max(float(p.damping_ratio[r]), loc.damping_ratio,
                   0.5 * (test.freq_hz[1] - test.freq_hz[0]) / loc.freq_hz) * loc.freq_hz
        distinct = not np.any(np.abs(kept_hz - loc.freq_hz) <= half)
        own += "" if distinct else ", the peak of a kept mode"
        resolved = loc.lines >= MIN_LINES
        own += "" if resolved else f", {loc.lines} line(s) in its half-power band"
        if (loc.evidence > need[r] and loc.snr > PEAK_SHARE * need[r] and loc.mpc >= MIN_MPC
                and loc.shift <= MAX_SHIFT and distinct and resolved):
            keep[r] = True
            why.append(f"{glob}; kept {own}")
        else:
            rejected.append(Rejection(float(p.freq_hz[r]), float(p.damping_ratio[r]),
                                      "support", f"{glob}; {own}"))
    return keep, why, rejected


def _residues(
    test: FrfTest, band: tuple[float, float], sel: np.ndarray, p: _Poles, lower: bool,
    min_snr: float, refine: bool,
) -> tuple[_Poles, LsfdResult]:
    """Run steps 2-3 and the optional refinement.

    LSFD residues (``_with_extra``), then the modes without support dropped (reported as
    rejections) and the residues re-estimated without them.
    """
    freq = test.freq_hz
    h_flat = test.frf.reshape(freq.size, -1)
    fit, extra = _with_extra(freq, h_flat, sel, p, test.quantity, band, lower)
    keep, why, dropped = _support_decisions(test, fit, sel, p, min_snr)
    p = _Poles(p.freq_hz[keep], p.damping_ratio[keep], p.freq_std_hz[keep],
               p.damping_std[keep], p.count[keep], extra, p.sweep, p.stability,
               list(p.rejected) + dropped, tuple(why))
    if dropped:
        fit = lsfd(freq, h_flat, np.concatenate([p.pole, extra]), test.quantity, band,
                   lower=lower)
    if refine and p.freq_hz.size:
        ref = refine_poles(freq, h_flat, p.freq_hz, p.damping_ratio, test.quantity, band,
                           lower=lower, extra_poles=extra)
        p = _Poles(ref.freq_hz, ref.damping_ratio, ref.freq_std_hz, ref.damping_std, p.count,
                   ref.extra_pole, p.sweep, p.stability, p.rejected, p.why)
        fit = lsfd(freq, h_flat, np.r_[p.pole, p.extra], test.quantity, band, lower=lower)
    return p, fit


def _shapes(
    test: FrfTest, lay: _Layout, residue: np.ndarray, poles: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Run step 4: (complex, real) shapes.

    Mass-normalised through the driving point, else unscaled from the first row of residues.
    """
    if lay.driving is not None:
        i_d, j_d = lay.driving
        row = residue[i_d, :, :] if lay.row_layout else residue[:, j_d, :]
        shapes = mass_normalised_shapes(row, poles, lay.d_index)
    else:
        row = residue[0, :, :] if lay.row_layout else residue[:, 0, :]
        shapes = unscaled_shapes(row, poles)
    return shapes, fix_sign(real_modes(shapes), lay.d_index)


def _shape_noise(test: FrfTest, lay: _Layout, sel: np.ndarray, p: _Poles) -> np.ndarray | None:
    """Each mode's relative shape noise from the coherence of the shapes' FRFs (step 4).

    The FRFs the shapes come from (``_shapes``' row), their coherence on the fitted lines and
    the test's averages (``meta["n_averages"]``) in ``ema.shapes.noise``; None without
    coherence.
    """
    if test.coherence is None:
        return None
    coh = test.coherence[sel]
    i_d, j_d = (0, 0) if lay.driving is None else lay.driving
    row = coh[:, i_d, :] if lay.row_layout else coh[:, :, j_d]
    col = None if lay.driving is None else lay.d_index
    return shape_noise_from_coherence(test.freq_hz[sel], row, test.meta.get("n_averages"),
                                      p.freq_hz, p.damping_ratio, col)


def _rigid(
    lay: _Layout, real_susp: np.ndarray, mass_line: np.ndarray, x_m: np.ndarray,
    known_mass_kg: float | None,
) -> RigidBody:
    """Step 6: the rigid body from the suspension modes, else from the mass line."""
    if lay.driving is None:
        return RigidBody(None, None, None)
    if real_susp.shape[1] >= 2:
        return rigid_body_from_modes(real_susp, x_m)
    i_d, j_d = lay.driving
    ml_row = mass_line[i_d, :] if lay.row_layout else mass_line[:, j_d]
    return rigid_body_from_mass_line(ml_row, x_m, float(x_m[lay.d_index]), known_mass_kg)


_EMPTY_NOTE_PEAKS = 8  # sum-MIF peaks named in a 'no mode' note


def _empty_notes(p: _Poles, peaks: PeakPick, method: str) -> list[str]:
    """Say why a fit found no mode (stderr and --json say it).

    The note names the highest sum-MIF peaks (the lines a user would look at first: on noisy
    data the peaks are many and the
    resonances are the tallest, not the first in frequency).
    """
    counts: dict[str, int] = {}
    for r in p.rejected:
        counts[r.reason] = counts.get(r.reason, 0) + 1
    why = ", ".join(f"{n} {k}" for k, n in counts.items())
    top = np.sort(peaks.freq_hz[np.argsort(peaks.height)[::-1][:_EMPTY_NOTE_PEAKS]])
    tallest = ", ".join(f"{f:.4g}" for f in top)
    if method == "peak":
        if not why:
            return ["no mode: no sum-MIF peak with prominence x4 and a half-power width in the "
                    "band"]
        return [f"no mode: every sum-MIF peak rejected ({why}); the highest at {tallest} Hz: "
                "a lower --min-snr accepts weaker peaks"]
    hint = (f"; the sum MIF has {peaks.freq_hz.size} peak(s), the highest at {tallest} Hz: "
            "try --method peak or a lower --min-snr" if peaks.freq_hz.size else "")
    return [f"no mode: candidates rejected ({why or 'no pole stable over the orders'}){hint}"]


@dataclass(frozen=True)
class _Prepared:
    """The band, notes, orientation, band mask and sum-MIF peaks of a test (before step 1)."""

    band: tuple[float, float]
    notes: list[str]
    lay: _Layout
    sel: np.ndarray
    mif: np.ndarray
    peaks: PeakPick


def _prepare(test: FrfTest, band_hz: tuple[float, float] | None) -> _Prepared:
    """Clip the band, orient the FRFs (step 0) and pick the sum-MIF peaks."""
    freq = test.freq_hz
    band, notes = clip_band(freq, band_hz)
    lay = _layout(test)
    if lay.driving is None:
        notes.append("no driving point (no impact node equals a response node): shapes are "
                     "unscaled (largest entry 1), no mass normalisation or rigid-body check")
    sel = (freq >= band[0]) & (freq <= band[1]) & (freq > 0)
    _require_usable(test.frf[sel], band)
    mif = sum_mif(test.frf[sel])
    peaks = pick_peaks(freq[sel], receptance_power(freq[sel], mif, test.quantity), band)
    return _Prepared(band, notes, lay, sel, mif, peaks)


def _mass_line(
    test: FrfTest, lay: _Layout, fit: LsfdResult, poles: np.ndarray, band: tuple[float, float],
    lower: bool,
) -> np.ndarray:
    """Return the lower residual L0 per FRF, re-estimated below the second bending mode."""
    n_resp, n_ref = test.frf.shape[1:]
    mass_line = fit.lower[:, 0].reshape(n_resp, n_ref)
    if lower and lay.driving is not None:
        est = low_band_mass_line(test.freq_hz, test.frf.reshape(test.freq_hz.size, -1), poles,
                                 test.quantity, band[0],
                                 lay.driving[0] * n_ref + lay.driving[1])
        if est is not None:
            mass_line = est.mass_line.reshape(n_resp, n_ref)
    return mass_line


def _window_and_warnings(
    test: FrfTest, p: _Poles, sel: np.ndarray
) -> tuple[np.ndarray, list[list[str]]]:
    """Run steps 5 and 7: the exponential window's damping and the per-mode warnings.

    The warnings are judged on the fitted (windowed) damping.
    """
    window = np.zeros(p.freq_hz.size)
    if test.exp_window_tau_s:
        window = 1.0 / (test.exp_window_tau_s * 2 * np.pi * p.freq_hz)
    freq = test.freq_hz
    coh = None if test.coherence is None else test.coherence[sel]
    warn = mode_warnings(p.freq_hz, p.damping_ratio, float(freq[1] - freq[0]), coh, freq[sel])
    merged = _merge_warnings(p.freq_hz, p.rejected)
    return window, [a + b for a, b in zip(warn, merged, strict=True)]


def fit_test(
    test: FrfTest,
    band_hz: tuple[float, float] | None = None,
    method: str = "lscf",
    max_order: int | None = None,
    suspension_max_hz: float = 20.0,
    known_mass_kg: float | None = None,
    min_snr: float = MIN_SNR,
    refine: bool = False,
) -> ModalFit:
    """Fit natural frequencies, damping ratios and mass-normalised shapes to a test.

    The steps are those of the module docstring, with no human picking.

    Parameters
    ----------
    test : FrfTest
        The FRFs (one or several references; without a driving point the shapes are
        unscaled).
    band_hz : tuple of float, optional
        (lo, hi) Hz fitted; default from 20 Hz (above the suspension) to the last line;
        clipped to the data with a note.
    method : str
        "lscf" (polyreference LSCF + stabilisation + LSFD) or "peak" (sum-MIF peaks,
        half-power damping + LSFD).
    max_order : int, optional
        Highest LSCF order (default max(12, 30 / number of polyreference references)).
    suspension_max_hz : float
        Modes below are the suspension's rigid-body modes, Hz.
    known_mass_kg : float, optional
        The bat's mass, kg, for the mass-line check when the band excludes the suspension
        modes.
    min_snr : float
        Support a mode needs (``support_threshold``, ``_support_decisions``); the dropped
        ones are reported as ``support`` rejections.
    refine : bool
        Refine all poles together by maximum likelihood (``ema.poles.refine``); the
        uncertainties are then the least-squares standard deviations.

    Returns
    -------
    ModalFit
        The modes, and why every candidate was kept or rejected.
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; use one of {', '.join(METHODS)}")
    freq = test.freq_hz
    pre = _prepare(test, band_hz)
    band, notes, lay, sel, peaks = pre.band, pre.notes, pre.lay, pre.sel, pre.peaks
    p = _select_poles(test, lay, band, method, max_order, peaks)
    lower = band[0] >= suspension_max_hz  # else the suspension modes are fitted as modes
    p, fit = _residues(test, band, sel, p, lower, min_snr, refine)
    m = p.freq_hz.size
    residue = fit.residue[:, :m].reshape(*test.frf.shape[1:], m)
    shapes, real = _shapes(test, lay, residue, p.pole)
    mass_line = _mass_line(test, lay, fit, p.pole, band, lower)
    window, warn = _window_and_warnings(test, p, sel)
    zr = p.damping_ratio - window
    x_m = test.x_m(lay.nodes)
    susp = p.freq_hz < suspension_max_hz
    h_band = test.frf[sel]
    synth = fit.synth.reshape(h_band.shape)
    el = ~susp
    if not el.any():
        notes += _empty_notes(p, peaks, method)
    noise = _shape_noise(test, lay, sel, p)
    return ModalFit(
        freq_hz=p.freq_hz[el], damping_ratio=zr[el],
        shapes=shapes[:, el], real_shapes=real[:, el],
        nodes=lay.nodes, x_m=x_m,
        driving_index=None if lay.d_index is None else int(lay.d_index),
        driving_frf=None if lay.driving is None else (int(lay.driving[0]),
                                                        int(lay.driving[1])),
        mpc=mpc(shapes[:, el]), mpd=mpd(shapes[:, el]),
        freq_std_hz=p.freq_std_hz[el], damping_std=p.damping_std[el],
        stable_count=p.count[el],
        synthesis_error=np.linalg.norm(h_band - synth, axis=0) / np.linalg.norm(h_band, axis=0),
        synthesis_error_total=float(np.linalg.norm(h_band - synth) / np.linalg.norm(h_band)),
        residue=residue[:, :, el],
        mass_line=mass_line,
        suspension_freq_hz=p.freq_hz[susp],
        suspension_damping_ratio=zr[susp],
        suspension_shapes=real[:, susp],
        rigid_body=_rigid(lay, real[:, susp], mass_line, x_m, known_mass_kg),
        window_damping=window[el],
        band_hz=band, method=method, quantity=test.quantity,
        band_freq_hz=freq[sel], synth=synth, mif=pre.mif,
        sweep=p.sweep, stability=p.stability, peaks=peaks,
        scaled=lay.driving is not None,
        rejected=tuple(sorted(p.rejected, key=lambda r: r.freq_hz)),
        warnings=tuple(tuple(w) for w, e in zip(warn, el, strict=True) if e),
        close_pairs=tuple(close_pairs(p.freq_hz[el], zr[el], real[:, el])),
        notes=tuple(notes),
        decisions=tuple(w for w, e in zip(p.why, el, strict=True) if e),
        shape_noise_rel=None if noise is None else noise[el],
    )
