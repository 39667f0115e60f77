"""What the verdict reports (../docs/inspection.md, steps 5 and 6).

The fit the verdict reads its core from (``read_fit``: a light fill re-read with part of its
hole possibly empty), the paired modes described (``mode_pairs``), the MSSO element map
(``element_map``) and the record of the evidence (``fit_evidence``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.correlate.measured import MeasuredModes
from updating.inspect.changes import RetestPairs
from updating.inspect.decision import Evidence
from updating.inspect.details import (
    CoreCandidate,
    ElementMap,
    FitEvidence,
    ModePair,
)
from updating.inspect.hypotheses import (
    N_CORE,
    N_NULL,
    NULL_NAMES,
    ChangeFit,
    Differences,
    ParamSpace,
    covariance,
    fit_partial,
    plane_shift,
)
from updating.inspect.kinds import KindFits
from updating.inspect.model import ChangePredictor
from updating.inspect.msso_map import msso_map
from updating.inspect.nested import Hypotheses, NestedTest
from updating.model.units import IN_TO_M
from updating.tails import chi2_ppf

MAP_MASS_NORMALISED = True
PARTIAL_LEVEL = 0.01
"""Level of the chi^2 test (one degree) by which a light fill's reading is described as a
partial fill (``fit.fit_partial``: part of the hole behind the plug empty). The reading itself
always comes from that fit (it contains the hole filled to the plug); neither changes the
verdict."""


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
    if (full.rss - partial.rss) / max(partial.rss / dof, 1.0) > chi2_ppf(1 - PARTIAL_LEVEL, 1):
        filled_in = (c.depth_m - c.plug_m - c.empty_m) / IN_TO_M
        reason = (f"it fits a hole {where} filled at its bottom {filled_in:.1f} in (fill/wood "
                  f"density {c.fill_density_ratio:.2f}) and empty for {c.empty_m / IN_TO_M:.1f}"
                  f" in behind the plug: hole-averaged fill {c.mean_fill_density_ratio:.2f}")
    else:
        reason = (f"it fits a core {where}, fill/wood density "
                  f"{c.mean_fill_density_ratio:.2f} (averaged over the hole)")
    return read, cov, space.reading(read.x, cov)["sd"], reason


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
             test: NestedTest, altered: bool | None, kinds: KindFits | None) -> Reading:
    """Choose the fit the verdict reports (module docstring, step 5).

    Parameters
    ----------
    predict, diff, space, hyp, test
        As for ``weigh_evidence``.
    altered : bool or None
        The decision.
    kinds : KindFits or None
        Every kind's fit, when the change was significant (``weigh_evidence``).

    Returns
    -------
    Reading
        When altered, the finding's fit: a core re-read with part of its hole possibly
        empty when its fill is light; else H0 (and H1, the generic change, for the record).
    """
    if not altered or kinds is None:
        return Reading(hyp.null, hyp.full, covariance(hyp.null, max(test.n - N_NULL, 1)), {})
    fit = kinds.fit
    if kinds.family != "core":
        return Reading(fit, fit, kinds.cov, {})
    sd = space.reading(fit.x, kinds.cov)["sd"]
    if fit.params.core.fill_density_ratio >= 1.0:
        return Reading(fit, fit, kinds.cov, sd)
    fit, cov, sd, reason = _light_fill_reading(predict, diff, space, hyp.sigma_rel, fit,
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
                 evidence: Evidence, reading: Reading, kinds: KindFits | None,
                 altered: bool | None, beta_shear: np.ndarray, offset_m: float,
                 msso: ElementMap) -> FitEvidence:
    """Record the evidence of a test made (``details.FitEvidence``).

    Parameters
    ----------
    diff, space, hyp, test
        As for ``weigh_evidence``.
    evidence : Evidence
        What the decision read.
    reading : Reading
        The reported fit.
    kinds : KindFits or None
        Every kind's fit (the core family's is the candidate core), when significant.
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
    null = hyp.null
    full = hyp.full if hyp.kinds is None else hyp.kinds.fits["local_change"]
    candidate, plug_m = CoreCandidate.from_json_dict(None), float("nan")
    if hyp.kinds is not None:
        core_fit = hyp.kinds.fits["core"]
        c = core_fit.params.core
        sd = space.reading(core_fit.x, covariance(core_fit, test.dof))["sd"]
        region_c = c.interval_m(space.profile.length_m)
        candidate = CoreCandidate((float(region_c[0]), float(region_c[1])), c.diameter_m,
                                  c.fill_density_ratio, sd)
        plug_m = c.plug_m
    core = reading.core_fit.params.core
    return FitEvidence(
        statistic="F (drift + a local change vs drift alone, nested least squares)",
        dof=(test.q, test.dof), p_value=test.p_value, rss_null=test.rss_null,
        rss_core=test.rss_core, n_data=test.n,
        shape_noise_rel=tuple(hyp.sigma_rel.tolist()),
        freq_noise_rel=tuple(diff.sigma_lnf.tolist()),
        null_fit=dict(zip(NULL_NAMES, map(float, null.x), strict=True)),
        null_at_bound=evidence.held_null, core_fit_at_bound=evidence.held_core,
        weight_change_rel=None if evidence.dlnw is None else float(np.expm1(evidence.dlnw)),
        element_source=_element_source(kinds.family if altered and kinds else None),
        element_beta_shear=tuple(beta_shear.tolist()),
        candidate_core=candidate,
        core_fit_moisture={"stiffness_scale": float(full.params.stiffness_scale),
                           "density_scale": float(full.params.density_scale)},
        sensor_shift_m=float(reading.fit.params.sensor_shift_m - space.sensor_mount_m),
        baseline_sensor_offset_m=offset_m, msso=msso,
        plug_m=plug_m, fill_modulus_ratio=space.fill_modulus_ratio,
        empty_m=core.empty_m if altered and core is not None else 0.0,
        local_change=dict(zip(("start_in", "length_in", "mass_change_rel",
                               "stiffness_change_rel"), map(float, full.x[N_NULL:]),
                              strict=True)),
        kind_scores={} if kinds is None else {k: float(v) for k, v in kinds.scores.items()},
        decided_on=evidence.decided_on)


def _element_source(family: str | None) -> str:
    """Say which model the verdict's element factors come from."""
    if family is None:
        return "drift-only model (no local change)"
    if family == "core":
        return "physical core fit (element-averaged section ratios)"
    return f"physical {family.replace('_', ' ')} fit (element-integrated changes)"


def element_map(profile, reference, baseline, retest, pairs: RetestPairs, drift, offset,
                sigma, sigma_lnf, fit_region_m=None) -> ElementMap:
    """Map the paired modes element by element (MSSO).

    The MSSO map of the paired modes (its ``error`` when the modes cannot be updated
    element by element), weighted with the median of the per-mode noise levels (the map
    takes one shape and one frequency level), and whether it agrees with the fit's region
    ``fit_region_m`` (``regions_agree``; None: no alteration found).
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
    return ElementMap(mp, agrees_with_fit=regions_agree(mp.region_m, fit_region_m))


def regions_agree(map_region, fit_region) -> bool:
    """Both say "no local change", or both regions overlap."""
    if map_region is None or fit_region is None:
        return map_region is None and fit_region is None
    return bool(map_region[0] < fit_region[1] and fit_region[0] < map_region[1])
