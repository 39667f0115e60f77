"""An alteration must not rest on one mode or one impact point: the leave-one-out check.

A finding the change's physics fits best (``kinds.classify``) is refitted with each paired
mode left out in turn, and with each test point's shape row left out in turn, H0 and the
finding's own family both warm-started from their fits on all the data (the shape noise
levels kept). Each leave-out gives the nested F test again,

    F_(-k) = ((RSS_0,(-k) - RSS_1,(-k)) / q) / max(RSS_1,(-k) / dof_(-k), 1),

and the finding read again. The finding survives a leave-out when the change stays
beyond drift (p below ``decision.CLEAR_LEVEL``; the floor on F is asked of all the data
only: one mode fewer lowers F by itself), its kind is the same, its reading still passes
its gate (``decision.kind_supported``) and its region overlaps the one read from all the
data. A finding that does not survive leaving out one mode or one point rests on that
datum alone: a mode of the wrong bending plane, a double hit, a loose accelerometer at one
tap, which no drift model can be asked to absorb.
The spread of the reading over the leave-outs is reported beside the finding (Cook 1977
reads the same influence of one observation on a least-squares fit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.inspect.decision import is_significant, kind_supported
from updating.inspect.finding import Finding
from updating.inspect.hypotheses import (
    N_NULL,
    ChangeFit,
    Differences,
    ParamSpace,
    covariance,
    fit_null,
)
from updating.inspect.kinds import N_PARAMS, read_finding, refit_family
from updating.inspect.local_change import N_SEGMENT
from updating.inspect.nested import nested_f
from updating.inspect.parallel import fork_map
from updating.model.units import IN_TO_M


@dataclass(frozen=True)
class LeftOut:
    """One leave-out: what was left out and what the test and the finding became.

    Attributes
    ----------
    what : str
        ``mode`` or ``point``.
    index : int
        The paired mode's index (in the pairing's order) or the point's row.
    label : str
        In the lab's words, e.g. "mode 6 (3094 Hz)", "the point at 31.0 in".
    F, p_value : float
        The nested test without it.
    survives : bool
        Still significant, the same kind, its reading past its gate.
    reading : dict
        The finding's reading without it, SI.
    region_m : tuple of float
        Its region without it, m from the knob end.
    """

    what: str
    index: int
    label: str
    F: float
    p_value: float
    survives: bool
    reading: dict
    region_m: tuple[float, float]

    def to_json_dict(self) -> dict:
        """Return the leave-out as JSON types (SI)."""
        return {"what": self.what, "index": self.index, "label": self.label,
                "F": float(self.F), "p_value": float(self.p_value),
                "survives": bool(self.survives),
                "reading": {k: float(v) for k, v in self.reading.items()},
                "region_m": [float(v) for v in self.region_m]}


@dataclass(frozen=True)
class Robustness:
    """Every leave-out of a finding (module docstring).

    Attributes
    ----------
    cases : tuple of LeftOut
        One per paired mode, then one per test point.
    """

    cases: tuple[LeftOut, ...] = ()

    @property
    def failing(self) -> tuple[LeftOut, ...]:
        """The leave-outs the finding does not survive."""
        return tuple(c for c in self.cases if not c.survives)

    @property
    def holds(self) -> bool:
        """Whether the finding survives every leave-out."""
        return not self.failing

    def spread(self) -> dict[str, tuple[float, float]]:
        """(lowest, highest) of each reading over the leave-outs, SI (start included)."""
        if not self.cases:
            return {}
        keys = set.intersection(*(set(c.reading) for c in self.cases))
        out = {k: (min(c.reading[k] for c in self.cases), max(c.reading[k] for c in self.cases))
               for k in sorted(keys)}
        starts = [c.region_m[0] for c in self.cases]
        out["region_start_m"] = (min(starts), max(starts))
        return out

    def to_json_dict(self) -> dict:
        """Return the leave-outs and the spread as JSON types (SI); {} without any."""
        if not self.cases:
            return {}
        return {"cases": [c.to_json_dict() for c in self.cases],
                "spread": {k: [float(a), float(b)] for k, (a, b) in self.spread().items()}}


def _judge_without(predict, diff: Differences, space: ParamSpace, family: str,
                   sigma: np.ndarray, null_x: np.ndarray, fit_x: np.ndarray,
                   finding: Finding, false_alarm: float) -> tuple[float, float, bool, Finding]:
    """(F, p, survives, finding) of the reduced changes."""
    null = fit_null(predict, diff, space, sigma, x0=null_x)
    fit = refit_family(predict, diff, space, family, sigma, fit_x)
    n = diff.n_data
    dof = max(n - (N_NULL + N_SEGMENT), 1)
    F, p = nested_f(null.rss, min(fit.rss, null.rss), N_SEGMENT, dof)
    cov = covariance(fit, max(n - N_NULL - N_PARAMS[family], 1))
    again = read_finding(family, fit, space, cov, predict)
    (a, b), (c, d) = finding.region_m, again.region_m
    survives = (is_significant(p, false_alarm) and again.kind == finding.kind
                and kind_supported(again) and a < d and c < b)
    return F, p, survives, again


def leave_one_out(predict, diff: Differences, space: ParamSpace, sigma_rel: np.ndarray,
                  null: ChangeFit, fit: ChangeFit, family: str, finding: Finding,
                  false_alarm: float, mode_labels: list[str], point_x_m: np.ndarray,
                  ) -> Robustness:
    """Refit the finding with each mode and each point left out (module docstring).

    Parameters
    ----------
    predict : ChangePredictor
        The reference's changes.
    diff : Differences
        The measured changes the finding was fitted to.
    space : ParamSpace
        The parameters' bounds (the core family's; the segment families' from it).
    sigma_rel : numpy.ndarray
        (m,) the modes' shape noise levels (kept).
    null, fit : ChangeFit
        H0 and the finding's family fitted to all the data (the warm starts).
    family : str
        The finding's family (``core``, ``added_mass``, ``diameter_loss``).
    finding : Finding
        The finding on all the data.
    false_alarm : float
        The significance level.
    mode_labels : list of str
        (m,) each paired mode in the lab's words.
    point_x_m : numpy.ndarray
        (n_points,) the test points' positions, m.

    Returns
    -------
    Robustness
        Every leave-out.
    """
    sigma = np.broadcast_to(np.asarray(sigma_rel, float), (diff.n_freq,))
    jobs = [("mode", k) for k in range(diff.n_freq)]
    jobs += [("point", j) for j in range(diff.dpsi.shape[0])]

    def run(job):
        what, k = job
        if what == "mode":
            d, s = diff.without_mode(k), np.delete(sigma, k)
        else:
            d, s = diff.without_point(k), sigma
        return _judge_without(predict, d, space, family, s, null.x, fit.x, finding,
                              false_alarm)

    cases = []
    for (what, k), (F, p, ok, again) in zip(jobs, fork_map(run, jobs), strict=True):
        label = mode_labels[k] if what == "mode" else \
            f"the point at {point_x_m[k] / IN_TO_M:.1f} in"
        cases.append(LeftOut(what, k, label, F, p, ok, dict(again.reading),
                             tuple(float(v) for v in again.region_m)))
    return Robustness(tuple(cases))
