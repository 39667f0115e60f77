"""The kind of a significant local change: every family fitted, the best one read.

Once the generic local change (``local_change.fit_segment``, family ``local_change``) is
significant, the families that are alterations or legal changes are fitted on the same data
and the same null: a core bored from the barrel end (``hypotheses.fit_core``), an added mass
and a loss of diameter (``local_change``), each started from its own scan and from the
generic change's stretch. The family with the best Akaike score gives the finding
(``finding``), read with standard uncertainties from its Jacobian; a core filled heavier
than any wood and too thin to be surely a practical core, with added mass as well
supported, is read as added mass
(``finding.prefer_added_mass``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.inspect.decision import kind_supported
from updating.inspect.finding import (
    Finding,
    akaike,
    choose_family,
    found,
    prefer_added_mass,
)
from updating.inspect.hypotheses import (
    MAX_NFEV_CORE,
    N_NULL,
    ChangeFit,
    Differences,
    ParamSpace,
    SigmaRel,
    covariance,
    fit_bounded,
    fit_core,
    residual_function,
)
from updating.inspect.kind_table import FAMILIES, read_kind
from updating.inspect.local_change import (
    N_SEGMENT,
    SegmentSpace,
    distinct_best,
    fit_segment,
    segment_scan,
    start_from,
)
from updating.inspect.parallel import fork_map
from updating.inspect.segments import segment_mass_kg
from updating.model.units import IN_TO_M

KIND_FAMILIES = ("core", "added_mass", "diameter_loss")
"""The families fitted to tell a significant change's kind (``fit_families``)."""
N_PARAMS = {name: len(f.params) for name, f in FAMILIES.items()}
"""Each family's parameters beyond the null's (``kind_table.FAMILIES``)."""


@dataclass(frozen=True)
class KindFits:
    """The families fitted to a significant change and the one chosen.

    Parameters
    ----------
    fits : dict
        Family name -> its ``ChangeFit`` (``core``, ``added_mass``, ``diameter_loss``,
        ``local_change``).
    scores : dict
        Family name -> Akaike score (``finding.akaike``).
    family : str
        The family chosen.
    finding : Finding
        What it reads.
    fit : ChangeFit
        The chosen family's fit.
    cov : ndarray
        Its parameters' covariance.
    """

    fits: dict
    scores: dict
    family: str
    finding: Finding
    fit: ChangeFit
    cov: np.ndarray


def segment_space(space: ParamSpace, family: str) -> SegmentSpace:
    """Return the segment family ``family`` on the null of a core's parameter space."""
    return SegmentSpace(space.profile, space.bounds, family, space.sensor_mount_m)


def family_space(space: ParamSpace, family: str) -> ParamSpace | SegmentSpace:
    """Return the parameter space of ``family``.

    The core's ``space`` itself, else the segment family's on its null (``segment_space``).
    """
    return space if family == "core" else segment_space(space, family)


def refit_family(predict, diff: Differences, space: ParamSpace, family: str,
                 sigma_rel: SigmaRel, x0: np.ndarray) -> ChangeFit:
    """Refit one family (``core`` or a segment family) from ``x0`` with the noise given.

    The refits of a fitted family: with another noise estimate, or on fewer data (a mode or
    a point left out); ``x0`` is clipped into the family's bounds.
    """
    fspace = family_space(space, family)
    lo, hi = fspace.lower(), fspace.upper()
    return fit_bounded(residual_function(predict, diff, fspace, sigma_rel), np.clip(x0, lo, hi),
                       lo, hi, fspace, diff, MAX_NFEV_CORE)


def fit_families(predict, diff: Differences, space: ParamSpace, sigma_rel: SigmaRel,
                 null: ChangeFit, generic: ChangeFit) -> dict[str, ChangeFit]:
    """Fit the core, added-mass and diameter-loss families (module docstring).

    Parameters
    ----------
    predict : ChangePredictor
        The bat's change predictor.
    diff : Differences
        The measured changes.
    space : ParamSpace
        The core family's space (its null bounds serve every family).
    sigma_rel : float or ndarray
        Relative shape noise per mode.
    null, generic : ChangeFit
        The null fit and the generic local change's fit.

    Returns
    -------
    dict
        Family name -> fit, with the generic change under ``local_change``.
    """
    gspace = segment_space(space, "local_change")

    def fit_family(family: str) -> ChangeFit:
        if family == "core":
            return fit_core(predict, diff, space, sigma_rel, null)
        fspace = segment_space(space, family)
        starts = [start_from(generic, gspace, fspace, predict)]
        starts += distinct_best(segment_scan(predict, diff, fspace, sigma_rel, null), 1)
        return fit_segment(predict, diff, fspace, sigma_rel, null, starts=starts)

    # the families are independent: one on each core (a family's own starts then share
    # the first core with it), their scans included
    return {"local_change": generic, **dict(zip(KIND_FAMILIES,
                                                fork_map(fit_family, KIND_FAMILIES),
                                                strict=True))}


def segment_reading(fit: ChangeFit, fspace: SegmentSpace, cov: np.ndarray,
                    predict) -> tuple[dict, dict]:
    """Read a segment family's fit: (reading, uncertainty), SI (``finding.Finding``)."""
    x = fit.x
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    at = fspace.index
    unc = {"region_start_m": float(sd[at("start_in")]) * IN_TO_M}
    if fspace.family == "added_mass":
        return ({"added_mass_kg": float(x[at("mass_g")]) * 1e-3},
                dict(unc, added_mass_kg=float(sd[at("mass_g")]) * 1e-3))
    if fspace.family == "diameter_loss":
        loss_in = float(x[at("loss_in")])
        removed = -segment_mass_kg(predict.system().model, (fspace.segment(x),))
        rel = float(sd[at("loss_in")]) / loss_in if loss_in > 0 else 0.0
        return ({"diameter_lost_m": loss_in * IN_TO_M, "removed_mass_kg": removed},
                dict(unc, diameter_lost_m=float(sd[at("loss_in")]) * IN_TO_M,
                     removed_mass_kg=abs(removed) * rel))
    return ({"mass_change_rel": float(x[at("mass_rel")]),
             "stiffness_change_rel": float(x[at("stiffness_rel")])},
            dict(unc, mass_change_rel=float(sd[at("mass_rel")]),
                 stiffness_change_rel=float(sd[at("stiffness_rel")])))


def read_finding(family: str, fit: ChangeFit, space: ParamSpace, cov: np.ndarray,
                 predict) -> Finding:
    """Read one family's fit as a finding: kind, rule, region, reading, uncertainty.

    The kind is the one the family's fit reads as (``kind_table.read_kind``).
    """
    length_m = space.profile.length_m
    if family == "core":
        r = space.reading(fit.x, cov)
        core = r["core"]
        region = core.interval_m(length_m)
        reading = {"core_diameter_m": core.diameter_m,
                   "fill_density_ratio": core.mean_fill_density_ratio}
        unc = {k: r["sd"][k] for k in ("region_start_m", "core_diameter_m",
                                        "fill_density_ratio")}
    else:
        fspace = segment_space(space, family)
        region = fspace.interval_m(fit.x)
        reading, unc = segment_reading(fit, fspace, cov, predict)
    region_in = (region[0] / IN_TO_M, region[1] / IN_TO_M)
    k = read_kind(family, region_in, length_m / IN_TO_M, reading)
    return found(k, region, reading, unc, family)


def classify(predict, diff: Differences, space: ParamSpace, sigma_rel: SigmaRel,
             null: ChangeFit, generic: ChangeFit) -> KindFits:
    """Fit every family and read the best one's finding (module docstring).

    The residual variance per datum of the generic fit (at least 1) scales every family's
    Akaike score, so that the comparison does not depend on how well the weights were
    guessed.
    """
    fits = fit_families(predict, diff, space, sigma_rel, null, generic)
    n = diff.n_data
    s2 = max(generic.rss / max(n - N_NULL - N_SEGMENT, 1), 1.0)
    scores = {f: akaike(fits[f].rss, N_NULL + N_PARAMS[f], s2) for f in fits}
    family = choose_family({f: scores[f] for f in KIND_FAMILIES}, scores["local_change"])
    fit = fits[family]
    cov = covariance(fit, max(n - N_NULL - N_PARAMS[family], 1))
    finding = read_finding(family, fit, space, cov, predict)
    if family == "core" and prefer_added_mass(finding.reading["fill_density_ratio"],
                                              kind_supported(finding), scores):
        family, fit = "added_mass", fits["added_mass"]
        cov = covariance(fit, max(n - N_NULL - N_PARAMS[family], 1))
        finding = read_finding(family, fit, space, cov, predict)
    return KindFits(fits, scores, family, finding, fit, cov)
