"""The measured changes a re-test is judged on (../docs/inspection.md, steps 1 and 2).

Modes paired re-test to baseline to the reference model (``pair_tests``), the checks that
the two tests can be compared (``comparability_reasons``), and the changes of the paired
modes' frequencies, shapes and weight with their noise levels (``differences``): per mode,
the fitter's frequency uncertainty, the model's error and the two bending planes' spread;
per point, shape noise relative to |phi| with a floor (``SHAPE_NOISE_FLOOR_SHARE``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from updating.correlate.measured import MeasuredModes
from updating.correlate.pairing import align_signs, pair_modes
from updating.inspect.checks import (
    amplitude_reason,
    coverage_reason,
    identity_reason,
    pairing_reason,
)
from updating.inspect.hypotheses import (
    FREQ_MODEL_ERROR_REL,
    Differences,
    plane_sigma,
    shape_noise_profile,
)
from updating.inspect.identity import ModeIdentity, mode_identity
from updating.inspect.model import ChangeParams, ChangePredictor
from updating.model.profile import Profile

ELASTIC_MIN_HZ = 20.0
FALLBACK_FREQ_STD_PER_ZETA = 0.05
"""Without the fitter's frequency uncertainty: sigma_f / f = 0.05 zeta (1/20 of the
half-power half-bandwidth)."""
MODEL_SHAPE_ERROR = 0.004
"""Relative error of a predicted shape change that the change model itself makes beside the
measured noise (caliper noise of the profile, mesh, calibration, and the nuisances' shapes it
models only to first order), added in quadrature (``measured_shape_noise``). Set on 40 clean
nuisance-rich fleet bats whose files carry coherence (seeds 900000-900039, development only):
at 0.002 their F's upper tail lay above F(q, dof)'s (5.3 and 9.5 the two largest; the nominal
99.9 % point is about 5.5), at 0.004 below it (largest 3.1), so that the nominal chance is
not optimistic; the 28 altered bats beside them were found alike at both (25)."""
SHAPE_NOISE_FLOOR_SHARE = 0.5
"""Shape noise per point: ~ sqrt(phi_jr^2 + k^2 rms_r^2). An averaged FRF's random error is
relative to |H| (var H / |H|^2 = (1 - gamma^2) / (2 n gamma^2)) and near a resonance
|H_j| ~ |phi_j|, so a shape is noisier where the mode moves more (handle, barrel end); k is
the floor near the nodes (other modes' response, leakage). On 30 clean fleet bats the null's
squared shape residuals grew in proportion to phi^2 with a per-bat floor k of 0-1.4
(median 0.3); 0.5 is the floor kept. Weighting every point of a mode alike let the
large-amplitude points' noise dominate and read as a core at the barrel end."""


def _rel_freq_std(m: MeasuredModes) -> np.ndarray:
    if m.freq_std_hz is not None and np.all(np.asarray(m.freq_std_hz) > 0):
        return np.asarray(m.freq_std_hz) / m.freq_hz
    return FALLBACK_FREQ_STD_PER_ZETA * np.maximum(np.asarray(m.damping_ratio), 1e-3)


@dataclass(frozen=True)
class RetestPairs:
    """Modes paired re-test to baseline to reference model.

    Attributes
    ----------
    baseline_index, retest_index
        (m,) indices into the two tests' modes.
    model_index
        (m,) index among the predictor's modes.
    mac
        (m,) MAC baseline-retest.
    mac_model
        (m,) MAC baseline-model.
    """

    baseline_index: np.ndarray
    retest_index: np.ndarray
    model_index: np.ndarray
    mac: np.ndarray
    mac_model: np.ndarray

    @property
    def n(self) -> int:
        """Return the number of pairs."""
        return int(self.baseline_index.size)

    def subset(self, keep: np.ndarray) -> RetestPairs:
        """Return the pairs selected by ``keep`` (a boolean mask or indices)."""
        return RetestPairs(self.baseline_index[keep], self.retest_index[keep],
                           self.model_index[keep], self.mac[keep], self.mac_model[keep])


def pair_tests(predict: ChangePredictor, baseline: MeasuredModes, retest: MeasuredModes,
               min_mac: float) -> RetestPairs:
    """Pair re-test to baseline (MAC and frequency) and baseline to the reference model."""
    ib, ir, mac_br = pair_modes(baseline.shapes, retest.shapes, freq_a_hz=baseline.freq_hz,
                                freq_b_hz=retest.freq_hz, min_mac=min_mac, max_rel_df=0.15)
    f_mod, phi_mod = predict(ChangeParams())
    elastic = np.flatnonzero(f_mod >= ELASTIC_MIN_HZ)
    jb, jm, mac_bm = pair_modes(baseline.shapes, phi_mod[:, elastic],
                                freq_a_hz=baseline.freq_hz, freq_b_hz=f_mod[elastic],
                                min_mac=min_mac, max_rel_df=0.3)
    to_model = dict(zip(jb.tolist(), elastic[jm].tolist(), strict=True))
    mac_model = dict(zip(jb.tolist(), mac_bm.tolist(), strict=True))
    keep = [k for k, b in enumerate(ib) if b in to_model]
    ib, ir = np.asarray(ib, int)[keep], np.asarray(ir, int)[keep]
    return RetestPairs(ib, ir, np.array([to_model[b] for b in ib], dtype=int),
                     np.asarray(mac_br, float)[keep],
                     np.array([mac_model[b] for b in ib], dtype=float))


def identify_pairs(predict: ChangePredictor, baseline: MeasuredModes, retest: MeasuredModes,
                   pairs: RetestPairs) -> tuple[RetestPairs, ModeIdentity]:
    """Keep the pairs whose bending plane can be told (``identity.mode_identity``).

    Returns the pairs the verdict is judged on and every pair's identity (its ``notes`` say
    which were left out and why).
    """
    f_mod, phi_mod = predict(ChangeParams())
    order = np.searchsorted(np.flatnonzero(f_mod >= ELASTIC_MIN_HZ), pairs.model_index)
    ib, ir = pairs.baseline_index, pairs.retest_index
    psi_b = baseline.shapes[:, ib]
    identity = mode_identity(
        baseline.freq_hz[ib], order, psi_b, align_signs(psi_b, retest.shapes[:, ir]),
        phi_mod[:, pairs.model_index],
        members_b=None if baseline.members is None else baseline.members[ib],
        members_r=None if retest.members is None else retest.members[ir],
        band_top_b_hz=baseline.band_top_hz, band_top_r_hz=retest.band_top_hz)
    return pairs.subset(identity.usable), identity


def differences(predict: ChangePredictor, baseline: MeasuredModes, retest: MeasuredModes,
                pairs: RetestPairs, dlnw: float | None) -> Differences:
    """Return the measured changes of the paired modes (and of the weight) and their weights."""
    ib, ir, jmod = pairs.baseline_index, pairs.retest_index, pairs.model_index
    f_mod, phi_mod = predict(ChangeParams())
    psi_b = baseline.shapes[:, ib]
    psi_r = align_signs(psi_b, retest.shapes[:, ir])
    phi0 = align_signs(psi_b, phi_mod[:, jmod])
    order = np.searchsorted(np.flatnonzero(f_mod >= ELASTIC_MIN_HZ), jmod)
    sig = np.sqrt(_rel_freq_std(baseline)[ib] ** 2 + _rel_freq_std(retest)[ir] ** 2
                  + FREQ_MODEL_ERROR_REL ** 2 + plane_sigma(order) ** 2)
    rms = np.hypot(np.sqrt(np.mean(psi_b**2, axis=0)), np.sqrt(np.mean(psi_r**2, axis=0)))
    scale = rms * shape_noise_profile(phi0, SHAPE_NOISE_FLOOR_SHARE)
    s_f, s_phi = shear_sensitivity(predict)
    return Differences(jmod, np.log(retest.freq_hz[ir] / baseline.freq_hz[ib]), sig,
                       psi_r - psi_b, scale, f_mod[jmod], phi0, dlnw,
                       predict.wood_mass_kg(ChangeParams()), s_f[jmod],
                       s_phi[:, jmod] * np.sign(np.einsum("ij,ij->j", phi_mod[:, jmod], phi0)),
                       sigma_meas=measured_shape_noise(baseline, retest, ib, ir, psi_b, psi_r))


def measured_shape_noise(baseline: MeasuredModes, retest: MeasuredModes, ib: np.ndarray,
                         ir: np.ndarray, psi_b: np.ndarray, psi_r: np.ndarray
                         ) -> np.ndarray | None:
    """Return each paired mode's relative shape noise as the two tests measured it.

    The weights' ``psi_scale`` carries hypot(rms_b, rms_r) of each mode, so the level that
    gives each entry of psi_r - psi_b the variance (s_b rms_b)^2 + (s_r rms_r)^2 is

        sigma_r = sqrt((s_b^2 rms_b^2 + s_r^2 rms_r^2) / (rms_b^2 + rms_r^2)),

    with the change model's own error ``MODEL_SHAPE_ERROR`` added in quadrature; s_b, s_r
    each test's ``MeasuredModes.shape_noise_rel`` (its coherence). None when either test has
    none.
    """
    if baseline.shape_noise_rel is None or retest.shape_noise_rel is None:
        return None
    s_b, s_r = baseline.shape_noise_rel[ib], retest.shape_noise_rel[ir]
    if not (np.all(np.isfinite(s_b)) and np.all(np.isfinite(s_r))):
        return None
    rb2, rr2 = np.mean(psi_b**2, axis=0), np.mean(psi_r**2, axis=0)
    level2 = (s_b**2 * rb2 + s_r**2 * rr2) / (rb2 + rr2)
    return np.sqrt(level2 + MODEL_SHAPE_ERROR**2)


def shear_sensitivity(predict: ChangePredictor,
                      step: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """Return the shear sensitivities of the reference's frequencies and shapes.

    (S_f, S_phi): S_f[r] = d ln f_r / d ln(E/G) (all of the predictor's modes) and
    S_phi[:, r] = d phi_r / d ln(E/G) at the test points (mass-normalised, signs of the
    reference's shapes) of the reference model, central differences at E fixed: how a
    change of the effective shear modulus -- the two bending planes mixed in another
    proportion -- moves each frequency and shape (``fit.plane_shift``,
    ``fit.plane_shape_shift``).
    """
    ref = predict.reference
    _, phi0 = predict(ChangeParams())
    f, phi = zip(*(predict.with_reference(replace(ref, e_over_g=ref.e_over_g * np.exp(s)))(
        ChangeParams()) for s in (-step, step)), strict=True)
    elastic = (f[0] >= ELASTIC_MIN_HZ) & (f[1] >= ELASTIC_MIN_HZ)
    s_f = np.zeros(f[0].size)
    s_f[elastic] = np.log(f[1][elastic] / f[0][elastic]) / (2 * step)
    s_phi = (align_signs(phi0, phi[1]) - align_signs(phi0, phi[0])) / (2 * step)
    s_phi[:, ~elastic] = 0.0
    return s_f, s_phi


def comparability_reasons(profile: Profile, baseline: MeasuredModes, retest: MeasuredModes,
                          pairs: RetestPairs, dlnw: float | None) -> list[str]:
    """Say why the two tests cannot be compared (module docstring, step 1); [] when they can.

    Parameters
    ----------
    profile : Profile
        The bat's outer profile.
    baseline, retest : MeasuredModes
        The two tests' modes at the same points.
    pairs : RetestPairs
        The pairing.
    dlnw : float or None
        ln(W_retest / W_registered), None when unknown.

    Returns
    -------
    list of str
        The failed checks' reasons (``updating.inspect.checks``).
    """
    reasons = [r for r in (coverage_reason(np.asarray(baseline.x_m, dtype=float),
                                           profile.length_m),
                           pairing_reason(pairs.n)) if r]
    if pairs.n >= 1:
        ib, ir = pairs.baseline_index, pairs.retest_index
        psi_r = align_signs(baseline.shapes[:, ib], retest.shapes[:, ir])
        reasons += [r for r in (
            amplitude_reason(baseline.shapes[:, ib], psi_r, baseline.freq_hz[ib]),
            identity_reason(np.log(retest.freq_hz[ir] / baseline.freq_hz[ib]), dlnw)) if r]
    return reasons
