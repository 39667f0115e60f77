"""Phase 3: the verdict on a re-tested bat (../docs/inspection.md).

1. Checks that the tests can be compared (``checks``): enough modes pair, the amplitudes
   agree as one bat's would (units, calibration), the re-test looks like the same bat
   (frequencies, weight), the test points see the barrel. A failed check: inconclusive.
2. Fit, to the changes retest - baseline of frequencies, shapes and weight, the model's
   changes model(theta) - model(reference) under two hypotheses:
   H0 (what an unaltered bat does between tests, physically bounded): uniform moisture
   (density, with its coupled stiffness) and temperature (stiffness), end-grain moisture at
   either end, the accelerometer re-mounted and possibly replaced, the two bending planes
   mixed in another proportion, 7 parameters;
   H1: H0 plus a filled core from the barrel end or inside the bat (plug, length, diameter,
   fill density ratio), 11 parameters.
3. Nested-model F test, residuals weighted by their estimated noise:

       F = ((RSS_0 - RSS_1) / q) / max(RSS_1 / (N - p_1), 1),  q = 4, p_1 = 11,

   p = P(F_{q, N-p_1} > F); significant when p < false_alarm; confidence = 1 - p.
4. Decision: altered only when the change is significant, the core that explains it is a
   practical one (``MIN_CORE_DIAMETER_IN``) and no nuisance is held at its physical bound,
   or no drift three times beyond the bounds explains the change either
   (``_core_beyond_drift``); inconclusive when the drift itself is beyond physical bounds or
   a nuisance at its bound and a core cannot be told apart; else not altered.
5. Reading: the H1 core (region, diameter, fill ratio) with standard uncertainties from the
   Jacobian, and the element factors it implies; a light fill re-read with part of its hole
   possibly empty (``fit.fit_partial``), its fill averaged over the hole.
6. The MSSO element map (``msso_map``), independent of the core fit: the re-test against the
   baseline-updated reference with the accepted drift removed (``details.msso``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
from scipy.stats import chi2
from scipy.stats import f as f_dist

from updating.correlate.measured import MeasuredModes
from updating.correlate.pairing import align_signs, pair_modes
from updating.inspect.checks import (
    amplitude_reason,
    coverage_reason,
    identity_reason,
    pairing_reason,
)
from updating.inspect.decision import CONFUSABLE, Evidence, decide, is_significant
from updating.inspect.details import (
    CoreCandidate,
    ElementMap,
    FitEvidence,
    InspectionDetails,
    ModePair,
    PositionScan,
)
from updating.inspect.hypotheses import (
    FREQ_MODEL_ERROR_REL,
    MAX_NFEV_CORE,
    N_CORE,
    N_NULL,
    NULL_NAMES,
    ChangeFit,
    Differences,
    NullBounds,
    ParamSpace,
    covariance,
    fit_bounded,
    fit_core,
    fit_null,
    fit_partial,
    plane_shift,
    plane_sigma,
    residual_function,
    shape_noise,
    shape_noise_profile,
)
from updating.inspect.model import ChangeParams, ChangePredictor, baseline_sensor_offset
from updating.inspect.msso_map import msso_map
from updating.inspect.retest_meta import RetestConditions
from updating.inspect.verdict import Verdict
from updating.model.profile import Profile
from updating.model.reference import BatReference
from updating.model.units import IN_TO_M
from updating.msso.core_elements import core_element_factors

ELASTIC_MIN_HZ = 20.0
FALLBACK_FREQ_STD_PER_ZETA = 0.05
"""Without the fitter's frequency uncertainty: sigma_f / f = 0.05 zeta (1/20 of the
half-power half-bandwidth)."""
INITIAL_SHAPE_NOISE = 0.01
SHAPE_NOISE_FLOOR_SHARE = 0.5
"""Shape noise per point: ~ sqrt(phi_jr^2 + k^2 rms_r^2). An averaged FRF's random error is
relative to |H| (var H / |H|^2 = (1 - gamma^2) / (2 n gamma^2)) and near a resonance
|H_j| ~ |phi_j|, so a shape is noisier where the mode moves more (handle, barrel end); k is
the floor near the nodes (other modes' response, leakage). On 30 clean fleet bats the null's
squared shape residuals grew in proportion to phi^2 with a per-bat floor k of 0-1.4
(median 0.3); 0.5 is the floor kept. Weighting every point of a mode alike let the
large-amplitude points' noise dominate and read as a core at the barrel end."""
MAP_MASS_NORMALISED = True
PARTIAL_LEVEL = 0.01
"""Level of the chi^2 test (one degree) by which a light fill's reading is described as a
partial fill (``fit.fit_partial``: part of the hole behind the plug empty). The reading itself
always comes from that fit (it contains the hole filled to the plug); neither changes the
verdict."""
def _rel_freq_std(m: MeasuredModes) -> np.ndarray:
    if m.freq_std_hz is not None and np.all(np.asarray(m.freq_std_hz) > 0):
        return np.asarray(m.freq_std_hz) / m.freq_hz
    return FALLBACK_FREQ_STD_PER_ZETA * np.maximum(np.asarray(m.damping_ratio), 1e-3)


def _check(profile: Profile, baseline: MeasuredModes, retest: MeasuredModes) -> None:
    if baseline.x_m.shape != retest.x_m.shape or not np.allclose(baseline.x_m, retest.x_m,
                                                                atol=1e-4):
        raise ValueError("baseline and re-test were measured at different points")
    if np.any(baseline.x_m < 0) or np.any(baseline.x_m > profile.length_m + 1e-6):
        raise ValueError("test points lie outside the bat's profile")


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
                       s_phi[:, jmod] * np.sign(np.einsum("ij,ij->j", phi_mod[:, jmod], phi0)))


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


def _element_map(profile, reference, baseline, retest, pairs: RetestPairs, drift, offset,
                 sigma, sigma_lnf) -> ElementMap:
    """Map the paired modes element by element (MSSO).

    The MSSO map of the paired modes (its ``error`` when the modes cannot be updated
    element by element), weighted with the median of the per-mode noise levels (the map
    takes one shape and one frequency level).
    """
    try:
        mp = msso_map(profile, reference, baseline.select(pairs.baseline_index),
                      retest.select(pairs.retest_index),
                      stiffness_scale=drift.stiffness_scale, density_scale=drift.density_scale,
                      sensor_shift_m=drift.sensor_shift_m, baseline_sensor_offset_m=offset,
                      shape_sigma=float(np.median(sigma)),
                      freq_sigma=float(np.median(sigma_lnf)) / np.sqrt(2),
                      mass_normalised=MAP_MASS_NORMALISED)
    except ValueError as exc:
        return ElementMap(error=str(exc))
    return ElementMap(mp)


def _agree(map_region, fit_region) -> bool:
    """Both say "no local change", or both regions overlap."""
    if map_region is None or fit_region is None:
        return map_region is None and fit_region is None
    return bool(map_region[0] < fit_region[1] and fit_region[0] < map_region[1])


@dataclass(frozen=True)
class Hypotheses:
    """H0 and H1 fitted.

    H0 and H1 fitted, with the shape noise they were weighted with ((m,), one relative
    level per paired mode, ``fit.shape_noise``).
    """

    null: ChangeFit
    full: ChangeFit
    sigma_rel: np.ndarray
    scan: PositionScan


def fit_hypotheses(predict: ChangePredictor, diff: Differences, space: ParamSpace,
                   n_starts: int) -> Hypotheses:
    """Fit H0 and H1 with each mode's shape noise.

    Shape noise of each mode from the null fit, then from the core fit (both refitted
    with it).
    """
    null = fit_null(predict, diff, space, INITIAL_SHAPE_NOISE)
    sigma = shape_noise(null, diff, INITIAL_SHAPE_NOISE, N_NULL)
    null = fit_null(predict, diff, space, sigma, x0=null.x)
    full, scan = fit_core(predict, diff, space, sigma, null, n_starts)
    sigma = shape_noise(full, diff, sigma, N_NULL + N_CORE)
    null = fit_null(predict, diff, space, sigma, x0=null.x)
    full, _ = fit_core(predict, diff, space, sigma, null, x0=full.x)
    if null.rss < full.rss:  # H1 contains H0 (p = q = 0): restart H1 from there
        x0 = np.concatenate([null.x, full.x[N_NULL:N_NULL + 2], [0.0, 0.0]])
        full = fit_bounded(residual_function(predict, diff, space, sigma), x0, space.lower(),
                           space.upper(), space, diff, MAX_NFEV_CORE)
    return Hypotheses(null, full, sigma, scan)


def nested_f(rss_null: float, rss_core: float, q: int, dof: int) -> tuple[float, float]:
    """Return F and p of the nested test.

    (F, p) of the nested test: F = ((RSS_0 - RSS_1) / q) / max(RSS_1 / dof, 1), the
    residual variance per datum not below 1 (the weights hold the noise floors,
    ``SHAPE_NOISE_FLOOR``, and data cleaner than them must not make model error
    significant); p = P(F_{q, dof} > F).
    """
    F = max(rss_null - rss_core, 0.0) / q / max(rss_core / dof, 1.0)
    return F, float(f_dist.sf(F, q, dof))


def _uniform_explanation(predict, diff, space, hyp: Hypotheses, q: int, dof: int,
                         false_alarm: float) -> tuple[float, float] | None:
    """Ask whether another bat explains the change.

    (stiffness %, density %) when a uniform change of the wood beyond physical bounds
    explains the change as well as the core does (another bat, not an alteration), else
    None.
    """
    wide = replace(space, bounds=space.bounds.widened())
    fit = fit_null(predict, diff, wide, hyp.sigma_rel, x0=hyp.null.x)
    rss1 = min(hyp.full.rss, hyp.null.rss)
    _, p = nested_f(fit.rss, rss1, q, dof)
    beyond = np.any(fit.x[:2] < space.bounds.lower[:2]) or \
        np.any(fit.x[:2] > space.bounds.upper[:2])
    if beyond and p >= false_alarm:
        return (100 * (fit.params.stiffness_scale - 1), 100 * (fit.params.density_scale - 1))
    return None


def _bounds_matter(predict, diff, space, hyp: Hypotheses, n: int,
                   level: float = 0.01) -> bool:
    """Ask whether the bounds on the drift matter.

    Do the data really want the null's nuisances beyond their physical bounds? The null
    refitted with every range three times as wide must fit significantly better
    (chi^2 test on the drop of the weighted residual, one degree per held parameter); a
    bound that only ends a flat valley does not make the verdict inconclusive.
    """
    held = NullBounds.held(hyp.null)
    wide = fit_null(predict, diff, replace(space, bounds=space.bounds.relaxed()),
                    hyp.sigma_rel, x0=hyp.null.x)
    s2 = max(wide.rss / max(n - N_NULL, 1), 1.0)
    return (hyp.null.rss - wide.rss) / s2 > chi2.ppf(1 - level, len(held))


def _core_beyond_drift(predict, diff, space, hyp: Hypotheses, q: int, dof: int,
                       false_alarm: float, factor: float = 3.0) -> float | None:
    """Ask whether the core beats drift beyond the bounds.

    F of the core against the null with every nuisance range ``factor`` times as wide
    (``NullBounds.relaxed``, priors kept) when the core is still significant there (p below
    ``false_alarm``, F at least ``F_FLOOR``), else None: a core fit that holds a nuisance
    at its bound is told apart from that drift when no drift three times as large explains
    the change.
    """
    wide = fit_null(predict, diff, replace(space, bounds=space.bounds.relaxed(factor)),
                    hyp.sigma_rel, x0=hyp.null.x)
    rss1 = min(hyp.full.rss, hyp.null.rss)
    F, p = nested_f(wide.rss, rss1, q, dof)
    return F if is_significant(F, p, false_alarm) else None


def _light_fill_reading(predict, diff, space, sigma_rel: np.ndarray, full: ChangeFit,
                        dof: int, length_m: float):
    """Read a light fill with part of its hole possibly empty.

    (fit, covariance, reading sd, reason) of a light fill read with part of its hole
    possibly empty (``fit_partial``). The family contains H1 (e = 0), so its fit replaces
    H1's whenever its residual is lower; its hole-averaged fill r (1 - e) is what a scale
    would miss, unbiased where the fill sits at the bottom of the hole. The reason calls it
    a partial fill only when the empty stretch is significant (``PARTIAL_LEVEL``).
    """
    partial = fit_partial(predict, diff, space, sigma_rel, full)
    dof = max(dof, 1)
    read = partial if partial.rss < full.rss else full
    cov = covariance(read, dof) if read is partial else covariance(full, dof + 1)
    c = read.params.core
    start_in, end_in = (v / IN_TO_M for v in c.interval_m(length_m))
    where = f"{c.diameter_m / IN_TO_M:.2f} in across at {start_in:.1f}-{end_in:.1f} in from " \
            "the knob end"
    if (full.rss - partial.rss) / max(partial.rss / dof, 1.0) > chi2.ppf(1 - PARTIAL_LEVEL, 1):
        filled_in = (c.depth_m - c.plug_m - c.empty_m) / IN_TO_M
        reason = (f"it fits a hole {where} filled at its bottom {filled_in:.1f} in (fill/wood "
                  f"density {c.fill_density_ratio:.2f}) and empty for {c.empty_m / IN_TO_M:.1f}"
                  f" in behind the plug: hole-averaged fill {c.mean_fill_density_ratio:.2f}")
    else:
        reason = (f"it fits a core {where}, fill/wood density "
                  f"{c.mean_fill_density_ratio:.2f} (averaged over the hole)")
    return read, cov, space.reading(read.x, cov)["sd"], reason


def _nan_verdict(predict: ChangePredictor, false_alarm: float, reasons: list[str],
                 details: InspectionDetails) -> Verdict:
    """Return an inconclusive verdict (no test made)."""
    factors = core_element_factors(predict.system().model, None)
    return Verdict(None, float("nan"), false_alarm, float("nan"), None, None, None, {},
                   factors.x0_m, factors.x1_m, factors.alpha, factors.beta, {}, (),
                   details, tuple(reasons))




@dataclass(frozen=True)
class NestedTest:
    """The nested F test of H1 (drift and a core) against H0 (drift alone).

    Attributes
    ----------
    F, p_value : float
        The statistic and P(F_{q, dof} > F) (``nested_f``).
    q, dof : int
        Its degrees of freedom: the core's parameters, the data less H1's parameters.
    n : int
        Number of data (frequencies, shapes, weight).
    rss_null, rss_core : float
        Weighted residual sums of squares of H0 and of H1 (the lower of the two fits).
    """

    F: float
    p_value: float
    q: int
    dof: int
    n: int
    rss_null: float
    rss_core: float


def nested_test(diff: Differences, hyp: Hypotheses) -> NestedTest:
    """Test H1 against H0 on the differences (module docstring, step 3).

    Parameters
    ----------
    diff : Differences
        The measured changes (their count, ``n_data``).
    hyp : Hypotheses
        H0 and H1 fitted.

    Returns
    -------
    NestedTest
        F, p and what they were computed from.
    """
    n, q = diff.n_data, N_CORE
    dof = max(n - (N_NULL + N_CORE), 1)
    rss0, rss1 = hyp.null.rss, min(hyp.full.rss, hyp.null.rss)
    F, p_value = nested_f(rss0, rss1, q, dof)
    return NestedTest(F, p_value, q, dof, n, rss0, rss1)


def weigh_evidence(predict: ChangePredictor, diff: Differences, space: ParamSpace,
                   hyp: Hypotheses, test: NestedTest, false_alarm: float,
                   dlnw: float | None) -> tuple[Evidence, dict]:
    """Gather what the decision reads, running only the checks its rules need.

    The uniform explanation is tried when the change is significant; drift three times
    beyond the bounds when a practical core needs a confusable nuisance at its bound; the
    relaxed bounds when the change is not significant and H0 holds a nuisance at a bound.

    Parameters
    ----------
    predict : ChangePredictor
        The reference model's changes.
    diff : Differences
        The measured changes.
    space : ParamSpace
        The parameters' bounds and priors.
    hyp : Hypotheses
        H0 and H1 fitted.
    test : NestedTest
        The nested test.
    false_alarm : float
        The significance level.
    dlnw : float or None
        ln(W_retest / W_registered), None when unknown.

    Returns
    -------
    evidence : Evidence
        The decision's input.
    candidate : dict
        The H1 core's reading with its standard uncertainties (``ParamSpace.reading``).
    """
    full, length_m = hyp.full, space.profile.length_m
    candidate = space.reading(full.x, covariance(full, test.dof))
    c = full.params.core
    d_in = c.diameter_m / IN_TO_M
    start_in, end_in = (v / IN_TO_M for v in c.interval_m(length_m))
    evidence = Evidence(
        F=test.F, p_value=test.p_value,
        significant=is_significant(test.F, test.p_value, false_alarm),
        core_text=(f"a core {d_in:.2f} in across at {start_in:.1f}-{end_in:.1f} in from the "
                   f"knob end, fill/wood density {c.fill_density_ratio:.2f}"),
        d_in=d_in, d_low_in=d_in - 2 * candidate["sd"]["core_diameter_m"] / IN_TO_M,
        held_null=tuple(NullBounds.held(hyp.null)),
        held_core=tuple(h for h in NullBounds.held(full) if h in CONFUSABLE), dlnw=dlnw)
    if evidence.significant:
        uniform = _uniform_explanation(predict, diff, space, hyp, test.q, test.dof,
                                       false_alarm)
        evidence = replace(evidence, uniform=uniform)
        if evidence.practical and evidence.held_core and uniform is None:
            evidence = replace(evidence, F_wide=_core_beyond_drift(
                predict, diff, space, hyp, test.q, test.dof, false_alarm))
    elif evidence.held_null:
        evidence = replace(evidence, drift_beyond_bounds=_bounds_matter(
            predict, diff, space, hyp, test.n))
    return evidence, candidate


@dataclass(frozen=True)
class Reading:
    """The fit the verdict reports, with its covariance and the core's uncertainties.

    Attributes
    ----------
    fit : ChangeFit
        H1 (or its partial-fill refit) when altered, else H0.
    core_fit : ChangeFit
        The fit the core is read from (H1 or its partial-fill refit).
    covariance : numpy.ndarray
        The reported fit's parameter covariance.
    core_sd : dict
        Standard uncertainties of the core's reading (``ParamSpace.reading``).
    reason : str or None
        The light fill's reading in words, replacing the last reason, or None.
    """

    fit: ChangeFit
    core_fit: ChangeFit
    covariance: np.ndarray
    core_sd: dict
    reason: str | None = None


def read_fit(predict: ChangePredictor, diff: Differences, space: ParamSpace, hyp: Hypotheses,
             test: NestedTest, altered: bool | None, candidate: dict) -> Reading:
    """Choose the fit the verdict reports (module docstring, step 5).

    Parameters
    ----------
    predict, diff, space, hyp, test
        As for ``weigh_evidence``.
    altered : bool or None
        The decision.
    candidate : dict
        The H1 core's reading (``weigh_evidence``).

    Returns
    -------
    Reading
        H1's core, re-read with part of its hole possibly empty when its fill is light, when
        altered; else H0 with the core's candidate kept for the record.
    """
    full = hyp.full
    if not altered:
        return Reading(hyp.null, full, covariance(hyp.null, max(test.n - N_NULL, 1)),
                       candidate["sd"])
    if full.params.core.fill_density_ratio >= 1.0:
        return Reading(full, full, covariance(full, test.dof), candidate["sd"])
    fit, cov, sd, reason = _light_fill_reading(predict, diff, space, hyp.sigma_rel, full,
                                               test.n - (N_NULL + N_CORE) - 1,
                                               space.profile.length_m)
    return Reading(fit, fit, cov, sd, reason)


def mode_pairs(predict: ChangePredictor, diff: Differences, pairs: RetestPairs,
               baseline: MeasuredModes, retest: MeasuredModes, null: ChangeFit,
               core: ChangeFit) -> tuple[ModePair, ...]:
    """Describe each paired mode: both tests, the reference, and the two fits' changes.

    Parameters
    ----------
    predict : ChangePredictor
        The reference model's changes.
    diff : Differences
        The measured changes (the paired modes' model index and reference frequency).
    pairs : RetestPairs
        The pairing.
    baseline, retest : MeasuredModes
        The two tests' modes.
    null, core : ChangeFit
        H0, and the fit the core is read from.

    Returns
    -------
    tuple of ModePair
        One per paired mode, in the pairing's order.
    """
    f_fit, _ = predict(core.params)
    f_null, _ = predict(null.params)
    shift_null, shift_fit = np.exp(plane_shift(diff, null.x)), np.exp(plane_shift(diff, core.x))
    modes = []
    for k in range(pairs.n):
        j = diff.model_index[k]
        fb = baseline.freq_hz[pairs.baseline_index[k]]
        fr = retest.freq_hz[pairs.retest_index[k]]
        modes.append(ModePair(
            float(fb), float(fr), mac=float(pairs.mac[k]), reference_hz=float(diff.f0[k]),
            mac_reference=float(pairs.mac_model[k]), change_pct=float(100 * (fr / fb - 1)),
            moisture_fit_change_pct=float(100 * (f_null[j] / diff.f0[k] * shift_null[k] - 1)),
            core_fit_change_pct=float(100 * (f_fit[j] / diff.f0[k] * shift_fit[k] - 1))))
    return tuple(modes)


def fit_evidence(diff: Differences, space: ParamSpace, hyp: Hypotheses, test: NestedTest,
                 evidence: Evidence, reading: Reading, candidate: dict, altered: bool | None,
                 beta_shear: np.ndarray, offset_m: float, msso: ElementMap) -> FitEvidence:
    """Record the evidence of a test made (``details.FitEvidence``).

    Parameters
    ----------
    diff, space, hyp, test
        As for ``weigh_evidence``.
    evidence : Evidence
        What the decision read.
    reading : Reading
        The reported fit.
    candidate : dict
        The H1 core's reading.
    altered : bool or None
        The decision.
    beta_shear : numpy.ndarray
        The element shear factors of the reported core (``core_element_factors``).
    offset_m : float
        The baseline's accelerometer offset from the reference's, m.
    msso : ElementMap
        The MSSO element map.

    Returns
    -------
    FitEvidence
        The record the verdict's details carry.
    """
    null, full = hyp.null, hyp.full
    c = full.params.core
    region_c = c.interval_m(space.profile.length_m)
    return FitEvidence(
        statistic="F (drift+core vs drift-only, nested least squares)",
        dof=(test.q, test.dof), p_value=test.p_value, rss_null=test.rss_null,
        rss_core=test.rss_core, n_data=test.n,
        shape_noise_rel=tuple(hyp.sigma_rel.tolist()),
        freq_noise_rel=tuple(diff.sigma_lnf.tolist()),
        null_fit=dict(zip(NULL_NAMES, map(float, null.x), strict=True)),
        null_at_bound=evidence.held_null, core_fit_at_bound=evidence.held_core,
        weight_change_rel=None if evidence.dlnw is None else float(np.expm1(evidence.dlnw)),
        element_source=("physical core fit (element-averaged section ratios)" if altered
                        else "drift-only model (no local change)"),
        element_beta_shear=tuple(beta_shear.tolist()),
        candidate_core=CoreCandidate((float(region_c[0]), float(region_c[1])), c.diameter_m,
                                     c.fill_density_ratio, candidate["sd"]),
        core_fit_moisture={"stiffness_scale": float(full.params.stiffness_scale),
                           "density_scale": float(full.params.density_scale)},
        sensor_shift_m=float(reading.fit.params.sensor_shift_m - space.sensor_mount_m),
        baseline_sensor_offset_m=offset_m, position_scan=hyp.scan, msso=msso,
        plug_m=c.plug_m, fill_modulus_ratio=space.fill_modulus_ratio,
        empty_m=reading.core_fit.params.core.empty_m if altered else 0.0)


def _weight_change(cond: RetestConditions, registered_weight_kg: float | None) -> float | None:
    """ln(W_retest / W_registered), None when either weight is unknown."""
    if cond.weight_kg is not None and registered_weight_kg:
        return float(np.log(cond.weight_kg / registered_weight_kg))
    return None


def _null_bounds(cond: RetestConditions, baseline_temperature_c: float | None,
                 baseline_sensor_mass_kg: float | None) -> NullBounds:
    """H0's physical bounds, narrowed by the temperature and accelerometer change if known."""
    dT = None
    if cond.temperature_c is not None and baseline_temperature_c is not None:
        dT = cond.temperature_c - baseline_temperature_c
    dm = None
    if cond.sensor_mass_kg is not None and baseline_sensor_mass_kg is not None:
        dm = cond.sensor_mass_kg - baseline_sensor_mass_kg
    return NullBounds.physical(dm, dT)


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


def _predictor(profile: Profile, reference: BatReference, baseline: MeasuredModes,
               retest: MeasuredModes) -> tuple[ChangePredictor, float]:
    """Return the reference's change predictor at the baseline's accelerometer.

    The reference model's changes at the test points, its accelerometer moved to the
    baseline's (``baseline_sensor_offset``), and that offset, m.
    """
    points = np.asarray(baseline.x_m, dtype=float)
    n_solve = max(baseline.freq_hz.size, retest.freq_hz.size) + 6
    predict = ChangePredictor(profile, reference, points, reference.sensor_x_m, n_solve)
    offset = baseline_sensor_offset(predict, baseline.freq_hz, baseline.shapes)
    return predict.at_sensor(reference.sensor_x_m + offset), offset


def inspect_retest(
    profile: Profile, reference: BatReference, baseline: MeasuredModes,
    retest: MeasuredModes, false_alarm: float = 0.01, *,
    conditions: RetestConditions | None = None, registered_weight_kg: float | None = None,
    baseline_temperature_c: float | None = None,
    baseline_sensor_mass_kg: float | None = None, fill_modulus_ratio: float = 0.0,
    n_starts: int = 2, min_mac: float = 0.8,
) -> Verdict:
    """Judge a re-test of a bat against its baseline test and reference (module docstring).

    Parameters
    ----------
    profile : Profile
        The bat's outer profile.
    reference : BatReference
        Its calibrated reference (from the baseline test).
    baseline, retest : MeasuredModes
        Identified elastic modes of the two tests, at the same points.
    false_alarm : float
        Significance level of the test "no local alteration".
    conditions : RetestConditions or None
        The re-test's retest.json (weight, accelerometer mass, temperature).
    registered_weight_kg : float or None
        The bat's weight at registration (meta.json), kg.
    baseline_temperature_c : float or None
        The lab's temperature at the baseline, deg C, if known.
    baseline_sensor_mass_kg : float or None
        The baseline's accelerometer mass, kg, if known (with the re-test's from
        ``conditions`` it fixes the change of accelerometer mass).
    fill_modulus_ratio : float
        Assumed fill stiffness of a core (fill/wood modulus).
    n_starts : int
        Number of core positions refined by least squares.
    min_mac : float
        Minimum MAC to pair two modes.

    Returns
    -------
    Verdict
        Altered, not altered or inconclusive, with the core read and the evidence.

    Raises
    ------
    ValueError
        When the tests were measured at different points.
    """
    t0 = time.perf_counter()
    cond = conditions or RetestConditions()
    _check(profile, baseline, retest)
    predict, offset = _predictor(profile, reference, baseline, retest)
    dlnw = _weight_change(cond, registered_weight_kg)
    pairs = pair_tests(predict, baseline, retest, min_mac)
    reasons = comparability_reasons(profile, baseline, retest, pairs, dlnw)
    if reasons:
        return _nan_verdict(predict, false_alarm, reasons,
                            InspectionDetails(pairs.n, time.perf_counter() - t0))
    diff = differences(predict, baseline, retest, pairs, dlnw)
    space = ParamSpace(profile, _null_bounds(cond, baseline_temperature_c,
                                             baseline_sensor_mass_kg),
                       fill_modulus_ratio, float(retest.sensor_x_m - baseline.sensor_x_m))
    hyp = fit_hypotheses(predict, diff, space, n_starts)
    test = nested_test(diff, hyp)
    evidence, candidate = weigh_evidence(predict, diff, space, hyp, test, false_alarm, dlnw)
    altered, reasons = decide(evidence)
    reading = read_fit(predict, diff, space, hyp, test, altered, candidate)
    if reading.reason is not None:
        reasons[-1] = reading.reason
    core = reading.core_fit.params.core if altered else None
    factors = core_element_factors(predict.system().model, core)
    # 6. the MSSO map, with the accepted model's drift (when there is a core, the null fit's
    # uniform scales absorb part of it and the map would show that as a change of the bat)
    ps = reading.fit.params
    msso = _element_map(profile, reference, baseline, retest, pairs, ps, offset,
                        hyp.sigma_rel, diff.sigma_lnf)
    region = None if core is None else core.interval_m(profile.length_m)
    if msso.result is not None:
        msso = replace(msso, agrees_with_fit=_agree(msso.region_m, region))
    record = fit_evidence(diff, space, hyp, test, evidence, reading, candidate, altered,
                          factors.beta_shear, offset, msso)
    sd = np.sqrt(np.clip(np.diag(reading.covariance), 0.0, None))
    uncertainty = {"stiffness_scale": sd[0] / 100, "density_scale": sd[1] / 100,
                   "sensor_shift_m": sd[2] * IN_TO_M}
    if core is not None:
        uncertainty.update(reading.core_sd)
    return Verdict(
        altered=altered, confidence=1.0 - test.p_value, false_alarm_rate=false_alarm,
        statistic=float(test.F),
        region_m=None if region is None else (float(region[0]), float(region[1])),
        core_diameter_m=None if core is None else float(core.diameter_m),
        fill_density_ratio=None if core is None else float(core.mean_fill_density_ratio),
        uncertainty={k: float(v) for k, v in uncertainty.items()},
        element_x0_m=factors.x0_m, element_x1_m=factors.x1_m,
        alpha=factors.alpha, beta=factors.beta,
        moisture={"stiffness_scale": float(ps.stiffness_scale),
                  "density_scale": float(ps.density_scale)},
        modes=mode_pairs(predict, diff, pairs, baseline, retest, hyp.null, reading.core_fit),
        details=InspectionDetails(pairs.n, time.perf_counter() - t0, record),
        reasons=tuple(reasons))


def inspect(profile: Profile, reference: BatReference, baseline: MeasuredModes,
            retest: MeasuredModes, false_alarm: float = 0.01,
            conditions: RetestConditions | None = None,
            registered: RetestConditions | None = None) -> Verdict:
    """Judge a re-test against the bat's reference: the method's one entry.

    Parameters
    ----------
    profile : Profile
        The bat's outer profile.
    reference : BatReference
        Its reference calibrated to the baseline (``updating.diagnose.calibrate_baseline``).
    baseline, retest : MeasuredModes
        The two tests' fitted elastic modes, the re-test's point rows in the baseline's
        order (``updating.correlate.points.match_points``).
    false_alarm : float
        Significance level of the test "no local alteration".
    conditions : RetestConditions or None
        The re-test's retest.json (weight, accelerometer mass, temperature).
    registered : RetestConditions or None
        The same keys of the bat's meta.json (its weight at registration, and the
        baseline's accelerometer mass and temperature when the lab recorded them).

    Returns
    -------
    Verdict
        The verdict (``inspect_retest``).
    """
    reg = registered or RetestConditions()
    return inspect_retest(profile, reference, baseline, retest, false_alarm=false_alarm,
                          conditions=conditions, registered_weight_kg=reg.weight_kg,
                          baseline_temperature_c=reg.temperature_c,
                          baseline_sensor_mass_kg=reg.sensor_mass_kg)
