"""The nested test of H1 (drift and a local change) against H0 (drift alone) and its evidence.

H0 and H1 fitted with each mode's shape noise (``fit_hypotheses``), the F test
(``nested_test``, module docstring of ``updating.inspect.run``, step 3), and the checks the
decision's rules read (``weigh_evidence``): another bat (a uniform change beyond physical
bounds), a core beyond drift three times the bounds, drift that wants its bounds.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from updating.inspect.decision import (
    CONFUSABLE,
    F_FLOOR,
    GRIP_MIN_G,
    Evidence,
    decided_chance,
    is_large,
    is_significant,
)
from updating.inspect.finding import Finding, describe, found
from updating.inspect.hypotheses import (
    END_MOISTURE_NAMES,
    GRIP_FROM,
    GRIP_G,
    GRIP_TO,
    HANDLE_MAX_IN,
    N_NULL,
    ChangeFit,
    Differences,
    NullBounds,
    ParamSpace,
    SigmaRel,
    covariance,
    fit_null,
    shape_noise,
)
from updating.inspect.kind_table import kind
from updating.inspect.kinds import N_PARAMS, KindFits, classify, refit_family, segment_space
from updating.inspect.local_change import N_SEGMENT, fit_segment
from updating.inspect.model import ChangePredictor
from updating.inspect.moisture_bounds import BEYOND_FACTOR
from updating.model.units import IN_TO_M
from updating.tails import chi2_ppf, f_sf

INITIAL_SHAPE_NOISE = 0.01


@dataclass(frozen=True)
class Hypotheses:
    """H0 and H1 fitted, with the shape noise they were weighted with.

    Attributes
    ----------
    null : ChangeFit
        H0: what an unaltered bat does between tests (grip substance included).
    full : ChangeFit
        H1: H0 and a local change anywhere along the bat: the best of the generic change
        and the kinds' families (``kinds``), each of at most ``N_SEGMENT`` parameters.
    sigma_rel : numpy.ndarray
        (m,) relative shape noise per paired mode (``hypotheses.shape_noise``).
    kinds : KindFits or None
        Every family fitted on the same null and noise (``kinds.classify``); ``full`` is
        the one with the lowest residual. None when the generic change was far from
        significant (``families_needed``): ``full`` is then the generic change.
    family : str
        The family ``full`` belongs to.
    null_h0, full_h0 : ChangeFit
        H0 and ``full``'s family refitted with the test's noise (``sigma_h0``): the test
        whose chance the verdict states (``nested_test``).
    sigma_h0 : numpy.ndarray
        (m,) relative shape noise per paired mode of the stated chance's test: as the two
        tests measured it (``Differences.sigma_meas``, their coherence) when they did,
        else estimated from H0's residual.
    """

    null: ChangeFit
    full: ChangeFit
    sigma_rel: np.ndarray
    kinds: KindFits | None
    family: str
    null_h0: ChangeFit
    full_h0: ChangeFit
    sigma_h0: np.ndarray


def fit_hypotheses(predict: ChangePredictor, diff: Differences, space: ParamSpace,
                   n_starts: int) -> Hypotheses:
    """Fit H0 and H1 (a local change of any kind) with two estimates of the shape noise.

    First the noise H0 leaves: each mode's shape noise from H0's residual (``shape_noise``,
    ``NOISE_PASSES`` times, H0 refitted with each estimate). Then the noise the best local
    change leaves: the generic local change fitted, the noise re-estimated from it, H0 and
    it refitted, every kind's family fitted (``kinds.classify``), the noise re-estimated
    from the best family (which fits an alteration of a known kind better than the generic
    change) and H0 and that family refitted: ``null``, ``full``, ``sigma_rel``, what the
    finding is read from. Last, the best family refitted with H0's noise (``full_h0``):
    the test whose chance is stated (``nested_test``, docs/inspection.md, "Two noises").

    The kinds' families are fitted only when the generic change may matter
    (``families_needed``): when the test with the generic change as H1 is far from
    significant and from large (its chance at least ``SCREEN_LEVEL``, F with its own noise
    below ``SCREEN_F_FIT``), H1 is the generic change and ``kinds`` is None: the families
    tell what a significant change is, and such a change is not near significance. F then
    differs from the one with the families only where a family, not the generic change,
    fitted best and set H1's noise (on clean bats, by a few tenths at F below 2), and a clean
    bat's inspection skips their fits: about half of its time.

    When both tests measured their noise (``Differences.sigma_meas``), the stated chance's
    test is weighted with it instead of H0's residual (docs/noise.md): neither hypothesis
    then sets the noise it is judged against, and an alteration's own misfit no longer
    inflates it; the overall level is still H1's residual when that exceeds the measured
    noise (``nested_f``'s denominator), which a model lacking something raises.
    """
    sigma: SigmaRel = INITIAL_SHAPE_NOISE
    null = fit_null(predict, diff, space, sigma)
    for _ in range(NOISE_PASSES):
        sigma = shape_noise(null, diff, sigma, N_NULL)
        null = fit_null(predict, diff, space, sigma, x0=null.x)
    null_h0, sigma_h0 = null, sigma
    if diff.sigma_meas is not None:
        sigma_h0 = diff.sigma_meas
        null_h0 = fit_null(predict, diff, space, sigma_h0, x0=null.x)
    gspace = segment_space(space, "local_change")
    generic = fit_segment(predict, diff, gspace, sigma, null, n_starts)
    sigma = shape_noise(generic, diff, sigma, N_NULL + N_SEGMENT)
    null = fit_null(predict, diff, space, sigma, x0=null.x)
    generic = fit_segment(predict, diff, gspace, sigma, null,
                          starts=[np.concatenate([null.x, generic.x[N_NULL:]])])
    screened = Hypotheses(null, generic, sigma, None, "local_change", null_h0,
                          refit_family(predict, diff, space, "local_change", sigma_h0,
                                       generic.x), sigma_h0)
    if not families_needed(nested_test(diff, screened)):
        return screened
    kinds = classify(predict, diff, space, sigma, null, generic)
    best = min(kinds.fits, key=lambda k: kinds.fits[k].rss)
    sigma = shape_noise(kinds.fits[best], diff, sigma, N_NULL + N_PARAMS[best])
    null = fit_null(predict, diff, space, sigma, x0=null.x)
    full = refit_family(predict, diff, space, best, sigma, kinds.fits[best].x)
    fits = dict(kinds.fits, **{best: full})
    dof = max(diff.n_data - N_NULL - N_PARAMS[kinds.family], 1)
    kinds = replace(kinds, fits=fits, fit=fits[kinds.family],
                    cov=covariance(fits[kinds.family], dof))
    full_h0 = refit_family(predict, diff, space, best, sigma_h0, full.x)
    return Hypotheses(null, full, sigma, kinds, best, null_h0, full_h0, sigma_h0)


SCREEN_LEVEL = 0.05
"""The chance (H0's noise) of the test with the generic change as H1 at or above which the
kinds' families are not fitted (``families_needed``): 50 times ``decision.CLEAR_LEVEL``."""
SCREEN_F_FIT = F_FLOOR / 2
"""The F with the noise the generic change leaves below which the kinds' families are not
fitted (``families_needed``): half ``decision.F_FLOOR``."""


def families_needed(screen: NestedTest) -> bool:
    """Tell whether the kinds' families must be fitted after the generic change.

    The decision reads the families when the change is significant (its chance below
    ``decision.CLEAR_LEVEL``) or large (``decision.F_FLOOR``); the screen asks 50 times
    that chance and half that F of the generic change, which fits any local change of mass
    and stiffness a family does, only less exactly. On the development and validation
    caches no core was screened out (the smallest cores' generic changes read chances of
    0.02-0.08 or F 6-7 with their own noise), and 82 of 90 clean bats were.

    Parameters
    ----------
    screen : NestedTest
        The nested test with the generic local change as H1 (``fit_hypotheses``).

    Returns
    -------
    bool
        False when the chance is at least ``SCREEN_LEVEL`` and F with the generic change's
        noise below ``SCREEN_F_FIT``, else True.
    """
    return bool(screen.p_value < SCREEN_LEVEL or screen.F_fit >= SCREEN_F_FIT)


NOISE_PASSES = 3
"""Re-estimates of the shape noise from H0's residual (each refits H0 with it): the
estimate is a fixed point, reached to a few 0.1 % in three."""


def nested_f(rss_null: float, rss_core: float, q: int, dof: int) -> tuple[float, float]:
    """Return F and p of the nested test.

    (F, p) of the nested test: F = ((RSS_0 - RSS_1) / q) / max(RSS_1 / dof, 1), the
    residual variance per datum not below 1 (the weights hold the noise floors,
    ``SHAPE_NOISE_FLOOR``, and data cleaner than them must not make model error
    significant); p = P(F_{q, dof} > F).
    """
    F = max(rss_null - rss_core, 0.0) / q / max(rss_core / dof, 1.0)
    return F, f_sf(F, q, dof)


@dataclass(frozen=True)
class NestedTest:
    """The nested F test of H1 (drift and a local change) against H0 (drift alone).

    Attributes
    ----------
    F, p_value : float
        The statistic and P(F_{q, dof} > F) (``nested_f``) with the shape noise H0 leaves:
        the chance the verdict states.
    q, dof : int
        Its degrees of freedom: the generic local change's parameters (``N_SEGMENT``), the
        data less H1's parameters.
    n : int
        Number of data (frequencies, shapes, weight).
    rss_null, rss_core : float
        Weighted residual sums of squares of H0 and of H1 (the lower of the two fits),
        with H0's noise.
    F_fit, p_fit : float
        The same test with the noise the best local change leaves: how large the change is
        against the test's own noise (``decision.F_FLOOR``).
    """

    F: float
    p_value: float
    q: int
    dof: int
    n: int
    rss_null: float
    rss_core: float
    F_fit: float = float("nan")
    p_fit: float = float("nan")


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
        F, p and what they were computed from: with the noise H0 leaves (the chance stated)
        and with the noise the best local change leaves (the change's size).
    """
    n, q = diff.n_data, N_SEGMENT
    dof = max(n - (N_NULL + N_SEGMENT), 1)
    rss0, rss1 = hyp.null_h0.rss, min(hyp.full_h0.rss, hyp.null_h0.rss)
    F, p_value = nested_f(rss0, rss1, q, dof)
    F_fit, p_fit = nested_f(hyp.null.rss, min(hyp.full.rss, hyp.null.rss), q, dof)
    return NestedTest(F, p_value, q, dof, n, rss0, rss1, F_fit, p_fit)


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
    return (hyp.null.rss - wide.rss) / s2 > chi2_ppf(1 - level, len(held))


def _core_beyond_drift(predict, diff, space, hyp: Hypotheses, q: int, dof: int,
                       false_alarm: float, held: tuple[str, ...],
                       clean_F: np.ndarray | None = None) -> float | None:
    """Ask whether the core beats drift beyond the bounds.

    The null refitted with each ``held`` nuisance's range widened (priors kept;
    ``NullBounds.relaxed``; the others where physics holds them): the moisture's to the
    ranges the lab's records leave beyond drift (``space.moisture``,
    ``moisture_bounds``: three times the physical ones when nothing is recorded), the
    accelerometer's ``BEYOND_FACTOR`` times as wide; and, when an end's moisture is held,
    the end grain's moisture reaching as far as those records let it
    (``MoistureBound.beyond_decay_m``; ``ChangePredictor.with_end_decay``: a front 6 in
    deep, not 2, when nothing is recorded), under both noises (``fit_hypotheses``): F of
    the core against it when the change is still beyond that drift at the stated chance
    (H0's noise: ``decision.is_significant`` of ``decision.decided_chance``, measured
    against the calibration's ``clean_F`` when one is given: a wider H0 leaves a clean
    bat a smaller F, so F's own clean re-tests bound its chance) and still large (H1's
    noise: ``decision.is_large``), else None. A core fit beside a nuisance held at its
    bound is told apart from that drift only when no drift that large explains the change.
    """
    relaxed = replace(space, bounds=space.bounds.relaxed(
        BEYOND_FACTOR, only=held, ranges=space.moisture.beyond_ranges()))
    ends = any(h in END_MOISTURE_NAMES for h in held)
    deep = predict.with_end_decay(space.moisture.beyond_decay_m) if ends else predict
    wide = fit_null(deep, diff, relaxed, hyp.sigma_rel, x0=hyp.null.x)
    F, p = nested_f(wide.rss, min(hyp.full.rss, hyp.null.rss), q, dof)
    wide_h0 = fit_null(deep, diff, relaxed, hyp.sigma_h0, x0=hyp.null_h0.x)
    F_h0, p_h0 = nested_f(wide_h0.rss, min(hyp.full_h0.rss, hyp.null_h0.rss), q, dof)
    p_h0 = decided_chance(F_h0, p_h0, clean_F, false_alarm)[0]
    return F if is_significant(p_h0, false_alarm) and is_large(F, p, false_alarm) else None


def _grip_in_null(null: ChangeFit, n: int) -> Finding | None:
    """Return the grip substance H0 read on the handle, when ``GRIP_MIN_G`` at 2 sigma."""
    sd = float(np.sqrt(max(covariance(null, max(n - N_NULL, 1))[GRIP_G, GRIP_G], 0.0)))
    mass_g = float(null.x[GRIP_G])
    if mass_g - 2 * sd < GRIP_MIN_G:
        return None
    region = (float(null.x[GRIP_FROM]) * IN_TO_M, float(null.x[GRIP_TO]) * IN_TO_M)
    return found(kind("grip"), region, {"added_mass_kg": mass_g * 1e-3},
                 {"added_mass_kg": sd * 1e-3}, "null")


def _as_grip(finding: Finding, null: ChangeFit, grip: Finding | None) -> Finding:
    """Read a finding on the handle, or just past it, as the grip substance it is.

    A change within 18 in of the knob (any family) while H0 reads a grip substance there is
    that substance laid unevenly: legal. Added mass that starts at most ``GRIP_PAST_IN``
    past 18 in while H0's substance reaches its 18 in bound, or within ``GRIP_GAP_IN`` of
    where H0's substance ends, is the substance spread past the rule: the bat must be
    cleaned, not an alteration. (On fleet bats with 1-8 g of pine tar to 19-24 in, H0 read
    2.3-16.9 in and H1 the rest, 17.5-22.2 in, as 2.9 g: an "insert" next to the grip.)
    """
    start_in, end_in = (v / IN_TO_M for v in finding.region_m)
    reach_held = null.x[GRIP_TO] >= HANDLE_MAX_IN - 0.1 and null.x[GRIP_G] >= GRIP_MIN_G
    beside_grip = grip is not None and start_in <= grip.region_m[1] / IN_TO_M + GRIP_GAP_IN
    if grip is not None and end_in <= HANDLE_MAX_IN + 0.5:
        total = grip.reading["added_mass_kg"] + finding.reading.get("added_mass_kg", 0.0)
        return replace(grip, region_m=(min(grip.region_m[0], finding.region_m[0]),
                                       max(grip.region_m[1], finding.region_m[1])),
                       reading={"added_mass_kg": total})
    if (finding.family == "added_mass" and (reach_held or beside_grip)
            and start_in <= HANDLE_MAX_IN + GRIP_PAST_IN):
        total = float(null.x[GRIP_G]) * 1e-3 + finding.reading["added_mass_kg"]
        past = kind("grip_past")
        return replace(finding, kind=past.finding, legal=past.legal, rule=past.rule,
                       region_m=(float(null.x[GRIP_FROM]) * IN_TO_M, finding.region_m[1]),
                       reading={"added_mass_kg": total})
    return finding


GRIP_PAST_IN = 4.0
"""How far past 18 in added mass may start and still be H0's grip substance spread on."""
GRIP_GAP_IN = 2.0
"""Gap between the end of H0's grip substance and added mass that starts after it, in, short
enough for the two to be one substance (a layer's fitted ends move by about an inch)."""


def weigh_evidence(predict: ChangePredictor, diff: Differences, space: ParamSpace,
                   hyp: Hypotheses, test: NestedTest, false_alarm: float,
                   dlnw: float | None, clean_F: np.ndarray | None = None,
                   ) -> tuple[Evidence, KindFits | None]:
    """Gather what the decision reads, running only the checks its rules need.

    When the change is significant, every kind is fitted and the best read
    (``kinds.classify``) and a uniform explanation is tried; drift three times beyond the
    bounds when an alteration large enough for its kind needs a confusable nuisance at its
    bound; the relaxed bounds when the change is not significant and H0 holds a nuisance at
    a bound.

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
    clean_F : numpy.ndarray or None
        The clean re-tests' F of a stored calibration of the bat's model: the chance the
        decision reads is measured on them (``decision.decided_chance``); None: nominal.

    Returns
    -------
    evidence : Evidence
        The decision's input.
    kinds : KindFits or None
        Every kind's fit and the finding, when the change is significant.
    """
    p_decided, decided_on = decided_chance(test.F, test.p_value, clean_F, false_alarm)
    # a change the screen passed over (``families_needed``: nominal chance 5 % or more) has
    # no kind read; no calibration makes it significant (one would sit far below nominal)
    significant = is_significant(p_decided, false_alarm) and hyp.kinds is not None
    large = is_large(test.F_fit, test.p_fit, false_alarm)
    grip = _grip_in_null(hyp.null, test.n)
    kinds = finding = None
    held_core: tuple[str, ...] = ()
    if significant or large:
        kinds = hyp.kinds
        finding = _as_grip(kinds.finding, hyp.null, grip)
        held_core = tuple(h for h in dict.fromkeys(NullBounds.held(kinds.fit)
                                                   + NullBounds.held(hyp.null))
                          if h in CONFUSABLE)  # at its bound in either: the core may be it
    evidence = Evidence(
        F=test.F, p_value=test.p_value, significant=significant,
        large=large, F_fit=test.F_fit, finding=finding,
        finding_text="" if finding is None else describe(finding),
        held_null=tuple(NullBounds.held(hyp.null)), held_core=held_core, dlnw=dlnw,
        grip=grip, decided_on=decided_on)
    if significant:
        uniform = _uniform_explanation(predict, diff, space, hyp, test.q, test.dof,
                                       false_alarm)
        evidence = replace(evidence, uniform=uniform)
        if evidence.supported and evidence.held_core and uniform is None:
            evidence = replace(evidence, F_wide=_core_beyond_drift(
                predict, diff, space, hyp, test.q, test.dof, false_alarm, held_core,
                clean_F))
    elif evidence.held_null:
        evidence = replace(evidence, drift_beyond_bounds=_bounds_matter(
            predict, diff, space, hyp, test.n))
    return evidence, kinds


STATISTIC_VERSION = 6
"""The version of the statistic F the verdict states and a calibration measures (version 1:
F with the noise the best local change leaves; 2: with the noise H0 leaves, ``nested_test``;
3: with the noise both tests measured when their files carry coherence, docs/noise.md;
4: with H0's moisture bounded by the lab's records, moisture readings, the room and the
dates, ``moisture_bounds``; 5: H1 the generic change alone when it is far from significant,
the kinds' families fitted only when it may matter, ``families_needed``; 6: the same test,
its fits' residuals and Jacobians read from one eigen-solution of every mode of a state,
``ChangePredictor.state``: the multi-start fits follow the new round-off to other minima on
some clean bats, F 0.07 -> 0.18 the most on the caches' 90, so it is measured again).
A stored calibration is used only by code of the same version (batlab.pipeline.chance).
Bump it whenever F's definition changes: whenever the code named in ``STATISTIC_DEFINITION``
changes (its docstrings and comments aside; the change predictor is named too, since the fits
follow its round-off), and then record that code's new
``STATISTIC_SOURCE_SHA256`` here and the new version's line in ``RECORDED`` of
tests/test_statistic_version.py, which fails until all three are done and prints the hash."""

STATISTIC_DEFINITION = (
    "updating.inspect.nested.nested_f", "updating.inspect.nested.nested_test",
    "updating.inspect.nested.fit_hypotheses", "updating.inspect.nested.NOISE_PASSES",
    "updating.inspect.nested.INITIAL_SHAPE_NOISE", "updating.inspect.nested.SCREEN_LEVEL",
    "updating.inspect.nested.SCREEN_F_FIT", "updating.inspect.nested.families_needed",
    "updating.inspect.hypotheses.shape_noise",
    "updating.inspect.hypotheses.fit_null", "updating.inspect.hypotheses.Residual",
    "updating.inspect.hypotheses.SHAPE_NOISE_FLOOR",
    "updating.inspect.hypotheses.SHAPE_NOISE_PRIOR_POINTS", "updating.inspect.hypotheses.N_NULL",
    "updating.inspect.local_change.N_SEGMENT",
    "updating.inspect.changes.measured_shape_noise", "updating.inspect.changes.MODEL_SHAPE_ERROR",
    "ema.shapes.noise.shape_noise_from_coherence", "ema.shapes.noise.line_variance",
    "ema.shapes.noise.UNKNOWN_AVERAGES",
    "updating.inspect.moisture_bounds.moisture_bound", "updating.inspect.moisture_bounds.dated",
    "updating.inspect.moisture_bounds.measured",
    "updating.inspect.moisture_bounds.READINGS_AS_PRIOR",
    "updating.inspect.model.ChangePredictor", "updating.inspect.sensitivity._predicted_change",
)
"""The code that defines F: the test, the fits it compares and their weights and noise."""

STATISTIC_SOURCE_SHA256 = "6b3ca321f03b259092fbec9cf59f9457e1fcda96118ff8ad0c4e4af95c4fdcd6"
"""SHA-256 of ``STATISTIC_DEFINITION``'s code (tests/test_statistic_version.py), recorded
with ``STATISTIC_VERSION``."""
