"""Phase 3: the verdict on a re-tested bat (../docs/inspection.md).

``inspect`` is the method's one entry; ``inspect_retest`` runs its steps, each in its own
module: the changes and the checks (``changes``, ``checks``), the two hypotheses and the
test (``hypotheses``, ``nested``), the decision (``decision``), the reading and the element
map (``reading``, ``msso_map``).

1. Checks that the tests can be compared (``checks``): enough modes pair, the amplitudes
   agree as one bat's would (units, calibration), the re-test looks like the same bat
   (frequencies, weight), the test points see the barrel. A failed check: inconclusive.
2. Fit, to the changes retest - baseline of frequencies, shapes and weight, the model's
   changes model(theta) - model(reference) under two hypotheses:
   H0 (what an unaltered bat does between tests, physically bounded): uniform moisture
   (density, with its coupled stiffness) and temperature (stiffness), end-grain moisture at
   either end, the accelerometer re-mounted and possibly replaced, the two bending planes
   mixed in another proportion, a grip substance on the handle (its mass, where it starts
   and ends), 10 parameters (``hypotheses.N_NULL``);
   H1: H0 plus a local change anywhere along the bat, the best of the generic change (start,
   length, mass and stiffness factors, ``local_change.N_SEGMENT`` = 4 parameters) and the
   kinds' families (a core from the barrel end or inside the bat: plug, length, diameter,
   fill density ratio; added mass; a lost diameter; ``kinds``).
3. Nested-model F test, residuals weighted by their estimated noise:

       F = ((RSS_0 - RSS_1) / q) / max(RSS_1 / (N - p_1), 1),  q = 4, p_1 = 14,

   p = P(F_{q, N-p_1} > F); significant when p < false_alarm; confidence = 1 - p.
4. Decision (``decision.RULES``, first rule that holds): altered only when the change is
   significant, the kind that explains it is large enough for its kind
   (``decision.kind_supported``: a core's diameter, an insert's or a coat's mass, a lost
   diameter) and no confusable nuisance is held at its physical bound, or no drift three
   times beyond the bounds explains the change either (``nested.weigh_evidence``); a grip
   substance on the handle is legal; inconclusive when another bat, drift beyond physical
   bounds, a nuisance at its bound beside the alteration, a change no kind fits or a weight
   change beyond moisture's explains it; else not altered.
5. Reading: the finding of the kind that fits best, with standard uncertainties from the
   Jacobian, and the element factors it implies; a light core fill re-read with part of its
   hole possibly empty (``hypotheses.fit_partial``), its fill averaged over the hole.
6. The MSSO element map (``msso_map``), independent of the core fit: the re-test against the
   baseline-updated reference with the accepted drift removed (``details.msso``).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from updating.correlate.measured import MeasuredModes
from updating.inspect.caliper_verdict import with_calipers
from updating.inspect.changes import (
    comparability_reasons,
    differences,
    identify_pairs,
    pair_tests,
)
from updating.inspect.decision import Evidence, decide
from updating.inspect.details import ElementMap, InspectionDetails
from updating.inspect.finding import Finding
from updating.inspect.hypotheses import NullBounds, ParamSpace
from updating.inspect.model import (
    END_DECAY_M,
    ChangeParams,
    ChangePredictor,
    baseline_sensor_offset,
)
from updating.inspect.moisture_bounds import NOMINAL, MoistureBound, moisture_bound
from updating.inspect.nested import fit_hypotheses, nested_test, weigh_evidence
from updating.inspect.plane_split_verdict import with_plane_split
from updating.inspect.reading import (
    Reading,
    element_map,
    fit_evidence,
    mode_pairs,
    read_fit,
)
from updating.inspect.retest_meta import RetestConditions
from updating.inspect.robustness import Robustness, leave_one_out
from updating.inspect.segments import element_factors
from updating.inspect.verdict import Verdict
from updating.model.calipers import CaliperSurvey
from updating.model.profile import Profile
from updating.model.reference import BatReference
from updating.model.units import IN_TO_M
from updating.msso.core_elements import core_element_factors


def _check(profile: Profile, baseline: MeasuredModes, retest: MeasuredModes) -> None:
    """Refuse tests measured at different points, or at points off the bat."""
    if baseline.x_m.shape != retest.x_m.shape or not np.allclose(baseline.x_m, retest.x_m,
                                                                atol=1e-4):
        raise ValueError("baseline and re-test were measured at different points")
    if np.any(baseline.x_m < 0) or np.any(baseline.x_m > profile.length_m + 1e-6):
        raise ValueError("test points lie outside the bat's profile")


def _nan_verdict(predict: ChangePredictor, false_alarm: float, reasons: list[str],
                 details: InspectionDetails) -> Verdict:
    """Return an inconclusive verdict (no test made)."""
    factors = core_element_factors(predict.system().model, None)
    return Verdict(None, float("nan"), false_alarm, float("nan"), None, None, None, {},
                   factors.x0_m, factors.x1_m, factors.alpha, factors.beta, {}, (),
                   details, tuple(reasons))


def _weight_change(cond: RetestConditions, registered_weight_kg: float | None) -> float | None:
    """ln(W_retest / W_registered), None when either weight is unknown."""
    if cond.weight_kg is not None and registered_weight_kg:
        return float(np.log(cond.weight_kg / registered_weight_kg))
    return None


def _null_bounds(cond: RetestConditions, baseline_temperature_c: float | None,
                 baseline_sensor_mass_kg: float | None,
                 moisture: MoistureBound = NOMINAL) -> NullBounds:
    """H0's physical bounds, narrowed by the temperature and accelerometer change if known.

    The moisture's as ``moisture`` bounds it (``moisture_bounds``).
    """
    dT = None
    if cond.temperature_c is not None and baseline_temperature_c is not None:
        dT = cond.temperature_c - baseline_temperature_c
    dm = None
    if cond.sensor_mass_kg is not None and baseline_sensor_mass_kg is not None:
        dm = cond.sensor_mass_kg - baseline_sensor_mass_kg
    return NullBounds.physical(dm, dT, moisture)


def _uncertainty(reading: Reading, finding: Finding | None) -> dict[str, float]:
    """Return the standard uncertainties of the reported drift and finding, SI."""
    sd = np.sqrt(np.clip(np.diag(reading.covariance), 0.0, None))
    out = {"stiffness_scale": sd[0] / 100, "density_scale": sd[1] / 100,
           "sensor_shift_m": sd[2] * IN_TO_M}
    if finding is not None:
        out.update(finding.uncertainty)
    return {k: float(v) for k, v in out.items()}


def _predictor(profile: Profile, reference: BatReference, baseline: MeasuredModes,
               retest: MeasuredModes,
               end_decay_m: float = END_DECAY_M) -> tuple[ChangePredictor, float]:
    """Return the reference's change predictor at the baseline's accelerometer.

    The reference model's changes at the test points, its accelerometer moved to the
    baseline's (``baseline_sensor_offset``), and that offset, m; the end grain's moisture
    decaying over ``end_decay_m`` from each end.
    """
    points = np.asarray(baseline.x_m, dtype=float)
    n_solve = max(baseline.freq_hz.size, retest.freq_hz.size) + 6
    predict = ChangePredictor(profile, reference, points, reference.sensor_x_m, n_solve,
                              end_decay_m)
    offset = baseline_sensor_offset(predict, baseline.freq_hz, baseline.shapes)
    return predict.at_sensor(reference.sensor_x_m + offset), offset


def inspect_retest(
    profile: Profile, reference: BatReference, baseline: MeasuredModes,
    retest: MeasuredModes, false_alarm: float = 0.01, *,
    conditions: RetestConditions | None = None, registered_weight_kg: float | None = None,
    baseline_temperature_c: float | None = None, baseline_sensor_mass_kg: float | None = None,
    fill_modulus_ratio: float = 0.0, n_starts: int = 2, min_mac: float = 0.8,
    with_map: bool = True, moisture: MoistureBound = NOMINAL, clean_F: np.ndarray | None = None,
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
        The baseline's accelerometer mass, kg, if known (fixes its change with ``conditions``).
    fill_modulus_ratio : float
        Assumed fill stiffness of a core (fill/wood modulus).
    n_starts, min_mac : int, float
        Core positions refined by least squares; the least MAC that pairs two modes.
    with_map : bool
        Compute the MSSO element map a report draws (``details.msso``; same verdict).
    moisture : MoistureBound
        H0's moisture as the tests' records bound it (``moisture_bounds``; NOMINAL: none).
    clean_F : numpy.ndarray or None
        A calibration's clean re-tests' F: the decision's chance is measured on them
        (``decision.decided_chance``); None: the F distribution's.

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
    predict, offset = _predictor(profile, reference, baseline, retest, moisture.end_decay_m)
    dlnw = _weight_change(cond, registered_weight_kg)
    pairs, identity = identify_pairs(predict, baseline, retest,
                                     pair_tests(predict, baseline, retest, min_mac))
    reasons = comparability_reasons(profile, baseline, retest, pairs, dlnw)
    if reasons:
        return _nan_verdict(predict, false_alarm, reasons + list(identity.notes),
                            InspectionDetails(pairs.n, time.perf_counter() - t0))
    diff = differences(predict, baseline, retest, pairs, dlnw)
    bounds = _null_bounds(cond, baseline_temperature_c, baseline_sensor_mass_kg, moisture)
    space = ParamSpace(profile, bounds, fill_modulus_ratio,
                       float(retest.sensor_x_m - baseline.sensor_x_m), moisture)
    hyp = fit_hypotheses(predict, diff, space, n_starts)
    test = nested_test(diff, hyp)
    evidence, kinds = weigh_evidence(predict, diff, space, hyp, test, false_alarm, dlnw, clean_F)
    evidence, robust = _robustness(predict, diff, space, hyp, kinds, evidence, false_alarm,
                                   list(identity.labels), baseline.x_m)
    altered, reasons = decide(evidence)
    reading = read_fit(predict, diff, space, hyp, test, altered, kinds)
    if reading.reason is not None:
        reasons[-1] = reading.reason
    finding = reported_finding(evidence, altered, reading, profile.length_m)
    core = reading.core_fit.params.core if altered and finding.kind == "core" else None
    factors = element_factors(predict.system().model, _finding_change(reading, finding, altered))
    # 6. the MSSO map, with the accepted model's drift (the null's scales would absorb a core)
    ps = reading.fit.params
    region = finding.region_m if altered else None
    msso = element_map(profile, reference, baseline, retest, pairs, ps, offset, hyp.sigma_rel,
                       diff.sigma_lnf, region) if with_map else ElementMap()
    record = replace(fit_evidence(diff, space, hyp, test, evidence, reading, kinds, altered,
                                  factors.beta_shear, offset, msso), F_fit=float(test.F_fit),
                     leave_one_out=robust.to_json_dict(), modes_left_out=identity.notes)
    return Verdict(
        altered=altered, confidence=1.0 - test.p_value, false_alarm_rate=false_alarm,
        statistic=float(test.F),
        region_m=None if region is None else (float(region[0]), float(region[1])),
        core_diameter_m=None if core is None else float(core.diameter_m),
        fill_density_ratio=None if core is None else float(core.mean_fill_density_ratio),
        uncertainty=_uncertainty(reading, finding if altered else None),
        element_x0_m=factors.x0_m, element_x1_m=factors.x1_m,
        alpha=factors.alpha, beta=factors.beta,
        moisture={"stiffness_scale": float(ps.stiffness_scale),
                  "density_scale": float(ps.density_scale)},
        modes=mode_pairs(predict, diff, pairs, baseline, retest, hyp.null, reading.core_fit),
        details=InspectionDetails(pairs.n, time.perf_counter() - t0, record),
        reasons=tuple(reasons) + identity.notes, finding=finding if finding.kind else None)


def _robustness(predict: ChangePredictor, diff, space: ParamSpace, hyp, kinds,
                evidence: Evidence, false_alarm: float, labels: list[str],
                point_x_m: np.ndarray) -> tuple[Evidence, Robustness]:
    """Leave each mode and point out of a finding that would alter (``robustness``).

    Returns the evidence with what the finding rests on alone (``Evidence.rests_on``) and
    every leave-out; an empty ``Robustness`` when the finding would not alter.
    """
    if not evidence.would_alter:
        return evidence, Robustness()
    robust = leave_one_out(predict, diff, space, hyp.sigma_rel, hyp.null, kinds.fit,
                           kinds.family, evidence.finding, false_alarm, labels, point_x_m)
    return replace(evidence, rests_on=tuple(
        f"{c.label} (F {c.F:.1f} without it)" for c in robust.failing)), robust


def _finding_change(reading: Reading, finding: Finding, altered: bool | None):
    """Return the reported state with only the finding's change (no grip or drift), or None."""
    if not altered:
        return None
    p = reading.fit.params
    own = p.segments[-1:] if finding.family != "core" else ()
    return replace(ChangeParams(), core=p.core, segments=own)


def reported_finding(evidence: Evidence, altered: bool | None, reading: Reading,
                     length_m: float) -> Finding:
    """Return the finding the verdict reports (an empty ``Finding`` when there is none).

    An alteration's finding (a core re-read from the reported fit, its light fill averaged
    over the hole); a grip substance, legal or spread past 18 in; what an inconclusive
    verdict could not tell apart; else the grip substance H0 read, if any.
    """
    f = evidence.finding
    if altered and f is not None and f.kind == "core":
        c = reading.core_fit.params.core
        return replace(f, region_m=c.interval_m(length_m),
                       reading={"core_diameter_m": c.diameter_m,
                                "fill_density_ratio": c.mean_fill_density_ratio},
                       uncertainty={**f.uncertainty, **reading.core_sd})
    if f is not None and (altered or evidence.grip_kind or altered is None):
        return f
    if altered is False and evidence.grip is not None:
        return evidence.grip
    return Finding("", False, (0.0, 0.0), "")


def inspect(profile: Profile, reference: BatReference, baseline: MeasuredModes,
            retest: MeasuredModes, false_alarm: float = 0.01,
            conditions: RetestConditions | None = None,
            registered: RetestConditions | None = None, with_map: bool = True,
            retest_profile: CaliperSurvey | None = None,
            clean_F: np.ndarray | None = None) -> Verdict:
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
        baseline's accelerometer mass, temperature, date, room and moisture readings when
        the lab recorded them: with the re-test's, they bound H0's moisture,
        ``moisture_bounds``).
    with_map : bool
        Compute the MSSO element map for the evidence (``inspect_retest``).
    retest_profile : CaliperSurvey or None
        The re-test's caliper profile, joined with the verdict (``caliper_verdict``).
    clean_F : numpy.ndarray or None
        F of a stored calibration's clean re-tests of the bat's model: the decision's chance
        is measured on them (``inspect_retest``); None: the F distribution's.

    Returns
    -------
    Verdict
        The verdict (``inspect_retest``), with the calipers' reading when given and the
        flat the bending planes' splits read, or why they cannot tell
        (``plane_split_verdict``).
    """
    reg = registered or RetestConditions()
    verdict = inspect_retest(profile, reference, baseline, retest, false_alarm=false_alarm,
                             conditions=conditions, registered_weight_kg=reg.weight_kg,
                             baseline_temperature_c=reg.temperature_c,
                             baseline_sensor_mass_kg=reg.sensor_mass_kg, with_map=with_map,
                             moisture=moisture_bound(reg, conditions, profile),
                             clean_F=clean_F)
    verdict = with_calipers(verdict, profile, retest_profile, reference.rho_kg_m3)
    return with_plane_split(verdict, profile, reference, baseline, retest)
