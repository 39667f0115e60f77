"""Automatic experimental modal analysis of one test: FRFs -> poles -> scaled modes.

``fit_test`` runs, with no human picking:

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
   trade off against them); otherwise the lower residual is the mass line.

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
from ema.poles.autopoles import auto_poles, take
from ema.poles.lscf import PoleSweep
from ema.poles.mif import PeakPick, pick_peaks, receptance_power, sum_mif
from ema.poles.refine import refine_poles
from ema.poles.stabilisation import SelectedPoles, Stability
from ema.shapes.complexity import mpc, mpd, real_modes
from ema.shapes.lsfd import QUANTITY_POWER, LsfdResult, lsfd
from ema.shapes.mass_line import RigidBody, rigid_body_from_mass_line, rigid_body_from_modes
from ema.shapes.scaling import fix_sign, mass_normalised_shapes

METHODS = ("lscf", "peak")


@dataclass(frozen=True)
class ModalFit:
    """Modes of one test, ascending in frequency.

    Attributes:
        freq_hz: (m,) undamped natural frequencies |lambda| / 2 pi, Hz.
        damping_ratio: (m,) viscous damping ratios (exponential window removed).
        shapes: (n_nodes, m) complex mass-normalised shapes, 1/sqrt(kg) (``ema.shapes.scaling``).
        real_shapes: (n_nodes, m) nearest real shapes, 1/sqrt(kg); sign: driving-point entry
            positive (largest-magnitude entry positive when the driving point is a node).
        nodes: (n_nodes,) node numbers of the shape rows (the impact nodes for a roving hammer).
        x_m: (n_nodes,) node positions from the knob end, m.
        driving_index: row of ``nodes`` that is the driving point.
        driving_frf: (response index, reference index) of the driving-point FRF.
        mpc: (m,) modal phase collinearity, 0..1 (1: real mode).
        mpd: (m,) mean phase deviation, degrees (0: real mode).
        freq_std_hz, damping_std: (m,) spread over the model orders (NaN for the peak method);
            with ``refine`` the least-squares standard deviations.
        stable_count: (m,) model orders at which the mode was stable (0 for the peak method).
        synthesis_error: (n_resp, n_ref) relative misfit ||H - H_synth|| / ||H|| in the band.
        synthesis_error_total: the same over all FRFs together.
        residue: (n_resp, n_ref, m) complex residues A_r (receptance pole-residue form).
        mass_line: (n_resp, n_ref) lower residual L0, 1/kg (the rigid-body flexibility).
        suspension_freq_hz, suspension_damping_ratio: modes below ``suspension_max_hz``.
        suspension_shapes: (n_nodes, s) their real mass-normalised shapes.
        rigid_body: mass / centre of mass / pitch inertia implied by the scaling.
        window_damping: (m,) damping removed for the exponential window (0 when none).
        band_hz, method, quantity: what was fitted.
        band_freq_hz: (F_band,) lines of the fit; synth: (F_band, n_resp, n_ref) synthesis.
        mif: (F_band,) sum MIF of the measured FRFs on those lines.
        sweep, stability, selected: LSCF stabilisation data (None for the peak method).
        peaks: the sum-MIF peaks (both methods: the quick cross-check).
    """

    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    real_shapes: np.ndarray
    nodes: np.ndarray
    x_m: np.ndarray
    driving_index: int
    driving_frf: tuple[int, int]
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
    selected: SelectedPoles | None
    peaks: PeakPick


def default_band(freq_hz: np.ndarray, low_hz: float = 20.0) -> tuple[float, float]:
    """(max(low_hz, first nonzero line), last line)."""
    f = np.asarray(freq_hz, dtype=float)
    return float(max(low_hz, f[f > 0][0])), float(f[-1])


def _poles(zeta: np.ndarray, freq_hz: np.ndarray) -> np.ndarray:
    wn = 2 * np.pi * np.asarray(freq_hz, dtype=float)
    z = np.asarray(zeta, dtype=float)
    return -z * wn + 1j * wn * np.sqrt(1 - z**2)


def _misfit(fit: LsfdResult, h: np.ndarray) -> float:
    return float(np.linalg.norm(h - fit.synth))


def _supported(
    fit: LsfdResult, h: np.ndarray, poles: np.ndarray, quantity: str, min_snr: float
) -> np.ndarray:
    """Mask of the modes whose contribution at resonance stands above the local misfit."""
    f = fit.freq_hz
    misfit = np.sqrt(np.mean(np.abs(h - fit.synth) ** 2, axis=1))  # (F,)
    s = 1j * np.abs(poles)  # i w_r
    term = s ** QUANTITY_POWER[quantity] * (
        fit.residue[:, : poles.size] / (s - poles) + np.conj(fit.residue[:, : poles.size])
        / (s - np.conj(poles))
    )  # (n_frf, m): each mode's own contribution at its resonance
    signal = np.sqrt(np.mean(np.abs(term) ** 2, axis=0))
    keep = np.ones(poles.size, dtype=bool)
    for r, lam in enumerate(poles):  # one window per mode
        half_bw = max(-lam.real / (2 * np.pi), f[1] - f[0])
        near = np.abs(f - abs(lam) / (2 * np.pi)) <= 5 * half_bw
        noise = np.sqrt(np.mean(misfit[near] ** 2)) if near.any() else 0.0
        keep[r] = signal[r] > min_snr * noise
    return keep


def fit_test(
    test: FrfTest,
    band_hz: tuple[float, float] | None = None,
    method: str = "lscf",
    max_order: int | None = None,
    suspension_max_hz: float = 20.0,
    known_mass_kg: float | None = None,
    min_snr: float = 10.0,
    refine: bool = False,
) -> ModalFit:
    """Natural frequencies, damping ratios and mass-normalised shapes of a test, automatically.

    Args:
        test: the FRFs (one driving point needed for the scaling).
        band_hz: (lo, hi) Hz fitted; default from 20 Hz (above the suspension) to the last line.
        method: "lscf" (polyreference LSCF + stabilisation + LSFD) or "peak" (sum-MIF peaks,
            half-power damping + LSFD).
        max_order: highest LSCF order (default 120 / number of polyreference references).
        suspension_max_hz: modes below are the suspension's rigid-body modes.
        known_mass_kg: the bat's mass, for the mass-line check when the band excludes the
            suspension modes.
        min_snr: modes whose resonant contribution is below min_snr x local misfit are dropped.
        refine: refine all poles together by maximum likelihood (``ema.poles.refine``); the
            uncertainties are then the least-squares standard deviations.
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; use one of {', '.join(METHODS)}")
    freq = test.freq_hz
    band = default_band(freq) if band_hz is None else (float(band_hz[0]), float(band_hz[1]))
    if not (band[0] < band[1] and band[0] >= freq[0] and band[1] <= freq[-1] + 1e-9):
        raise ValueError(
            f"band {band[0]:g}-{band[1]:g} Hz is not inside the test's {freq[0]:g}-{freq[-1]:g} Hz"
        )
    i_d, j_d = test.driving_point
    n_resp, n_ref = test.frf.shape[1:]
    row_layout = n_ref >= n_resp  # shapes along the references (roving hammer)
    h_poly = np.transpose(test.frf, (0, 2, 1)) if row_layout else test.frf
    nodes = test.reference_nodes if row_layout else test.response_nodes
    d_index = j_d if row_layout else i_d
    sel = (freq >= band[0]) & (freq <= band[1]) & (freq > 0)
    mif = sum_mif(test.frf[sel])
    peaks = pick_peaks(freq[sel], receptance_power(freq[sel], mif, test.quantity), band)

    sweep = stab = selected = None
    extra = np.zeros(0, dtype=complex)
    if method == "lscf":
        n_poly_ref = h_poly.shape[2]
        p_max = int(max_order) if max_order else max(12, 30 // n_poly_ref)
        auto = auto_poles(freq, h_poly, band, p_max)
        sweep, stab, selected = auto.sweep, auto.stability, auto.modes
        extra = np.concatenate([auto.outside.pole, auto.computational])
        fr, zr = selected.freq_hz, selected.damping_ratio
        f_std, z_std, count = selected.freq_std_hz, selected.damping_std, selected.count
    else:
        fr, zr = peaks.freq_hz, peaks.damping_ratio
        f_std = np.full(fr.size, np.nan)
        z_std = np.full(fr.size, np.nan)
        count = np.zeros(fr.size, dtype=int)

    h_flat = test.frf.reshape(freq.size, -1)
    poles = _poles(zr, fr)
    m = poles.size
    lower = band[0] >= suspension_max_hz  # else the suspension modes are fitted as modes
    fit = lsfd(freq, h_flat, poles, test.quantity, band, lower=lower)
    if extra.size:  # computational poles only when they explain the band edges better
        with_extra = lsfd(freq, h_flat, np.r_[poles, extra], test.quantity, band, lower=lower)
        base = _misfit(fit, h_flat[sel])
        better = _misfit(with_extra, h_flat[sel]) < 0.95 * base
        if better and base > 1e-4 * np.linalg.norm(h_flat[sel]):
            fit = with_extra
        else:
            extra = extra[:0]
    keep = _supported(fit, h_flat[sel], poles, test.quantity, min_snr)
    if not keep.all():
        fr, zr, f_std, z_std, count = (a[keep] for a in (fr, zr, f_std, z_std, count))
        poles = poles[keep]
        m = poles.size
        if selected is not None:
            selected = take(selected, keep)
        fit = lsfd(freq, h_flat, np.concatenate([poles, extra]), test.quantity, band, lower=lower)

    if refine and m:
        ref = refine_poles(freq, h_flat, fr, zr, test.quantity, band, lower=lower,
                           extra_poles=extra)
        fr, zr, f_std, z_std, poles, extra = (ref.freq_hz, ref.damping_ratio, ref.freq_std_hz,
                                              ref.damping_std, ref.pole, ref.extra_pole)
        fit = lsfd(freq, h_flat, np.r_[poles, extra], test.quantity, band, lower=lower)

    residue = fit.residue[:, :m].reshape(n_resp, n_ref, m)
    row = residue[i_d, :, :] if row_layout else residue[:, j_d, :]
    shapes = mass_normalised_shapes(row, poles, d_index)
    real = fix_sign(real_modes(shapes), d_index)
    mass_line = fit.lower[:, 0].reshape(n_resp, n_ref)

    window = np.zeros(fr.size)
    if test.exp_window_tau_s:
        window = 1.0 / (test.exp_window_tau_s * 2 * np.pi * fr)
    zr = zr - window

    x_m = test.x_m(nodes)
    susp = fr < suspension_max_hz
    if susp.sum() >= 2:
        rigid = rigid_body_from_modes(real[:, susp], x_m)
    else:
        ml_row = mass_line[i_d, :] if row_layout else mass_line[:, j_d]
        rigid = rigid_body_from_mass_line(ml_row, x_m, float(x_m[d_index]), known_mass_kg)

    h_band = test.frf[sel]
    synth = fit.synth.reshape(h_band.shape)
    err = np.linalg.norm(h_band - synth, axis=0) / np.linalg.norm(h_band, axis=0)
    err_total = float(np.linalg.norm(h_band - synth) / np.linalg.norm(h_band))
    el = ~susp
    return ModalFit(
        freq_hz=fr[el],
        damping_ratio=zr[el],
        shapes=shapes[:, el],
        real_shapes=real[:, el],
        nodes=np.asarray(nodes),
        x_m=x_m,
        driving_index=int(d_index),
        driving_frf=(int(i_d), int(j_d)),
        mpc=mpc(shapes[:, el]),
        mpd=mpd(shapes[:, el]),
        freq_std_hz=f_std[el],
        damping_std=z_std[el],
        stable_count=count[el],
        synthesis_error=err,
        synthesis_error_total=err_total,
        residue=residue[:, :, el],
        mass_line=mass_line,
        suspension_freq_hz=fr[susp],
        suspension_damping_ratio=zr[susp],
        suspension_shapes=real[:, susp],
        rigid_body=rigid,
        window_damping=window[el],
        band_hz=band,
        method=method,
        quantity=test.quantity,
        band_freq_hz=freq[sel],
        synth=synth,
        mif=mif,
        sweep=sweep,
        stability=stab,
        selected=selected,
        peaks=peaks,
    )
