"""The nested test of H1 (drift and a core) against H0 (drift alone) and its evidence.

H0 and H1 fitted with each mode's shape noise (``fit_hypotheses``), the F test
(``nested_test``, module docstring of ``updating.inspect.run``, step 3), and the checks the
decision's rules read (``weigh_evidence``): another bat (a uniform change beyond physical
bounds), a core beyond drift three times the bounds, drift that wants its bounds.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.stats import chi2
from scipy.stats import f as f_dist

from updating.inspect.decision import CONFUSABLE, Evidence, is_significant
from updating.inspect.details import (
    PositionScan,
)
from updating.inspect.hypotheses import (
    MAX_NFEV_CORE,
    N_CORE,
    N_NULL,
    ChangeFit,
    Differences,
    NullBounds,
    ParamSpace,
    covariance,
    fit_bounded,
    fit_core,
    fit_null,
    residual_function,
    shape_noise,
)
from updating.inspect.model import ChangePredictor
from updating.model.units import IN_TO_M

INITIAL_SHAPE_NOISE = 0.01


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
