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

Each leave-out is first predicted to first order (``linearised``): from the fits on all the
data (x*, weighted residual r, Jacobian J, the parameters at a bound held), leaving out the
rows R moves the free parameters by the Gauss-Newton step

    dx = -(J_R^T J_R)^+ J_R^T r_R,     RSS_(-k) ~ ||r_R + J_R dx||^2,

which since J^T r = 0 at x* is the pull of the rows left out (Cook's one-step
approximation; a parameter the step would take past its bound is held there; the fits must
be the ones weighted with the kept noise levels, else every leave-out is refitted). Where that
prediction survives by far (p below ``LINEAR_MARGIN`` times the level, the same kind past
its gate) and the data left out are not influential (Cook's distance of either fit at most
``COOK_MAX``) it is taken; every other leave-out is refitted. A finding resting on one
datum is thus always judged by a refit: only clear survivals are predicted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.inspect.decision import CLEAR_LEVEL, is_significant, kind_supported
from updating.inspect.finding import Finding
from updating.inspect.hypotheses import (
    N_NULL,
    ChangeFit,
    Differences,
    ParamSpace,
    covariance,
    fit_null,
    residual_function,
)
from updating.inspect.kinds import N_PARAMS, family_space, read_finding, refit_family
from updating.inspect.local_change import N_SEGMENT
from updating.inspect.nested import nested_f
from updating.inspect.parallel import fork_map
from updating.lsq import LsqSolution
from updating.model.units import IN_TO_M

COOK_MAX = 1.0
"""A leave-out whose data pull either fit further than this Cook's distance (``cook_distance``;
Cook's own mark of an influential observation) is refitted, however far it survives: a
finding that leans on a datum is judged by refits."""
LINEAR_MARGIN = 0.01
"""A leave-out predicted to first order is taken when its chance is below this fraction of
the level it must pass (``decision.CLEAR_LEVEL``): 100 times beyond it; else it is refitted."""


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
    refitted : bool
        Whether the fits were made again without it (False: predicted to first order,
        ``linearised``, and survived by far).
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
    refitted: bool = True

    def to_json_dict(self) -> dict:
        """Return the leave-out as JSON types (SI)."""
        return {"what": self.what, "index": self.index, "label": self.label,
                "F": float(self.F), "p_value": float(self.p_value),
                "survives": bool(self.survives), "refitted": bool(self.refitted),
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


def left_out_rows(diff: Differences, what: str, k: int) -> np.ndarray:
    """Return the residual rows (``hypotheses.Residual``) of paired mode or point ``k``.

    The residual holds the m frequencies, then the (n_points, m) shapes row by row, then
    the weight and the priors; a mode is its frequency and its column of shapes, a point
    its row of shapes.
    """
    n_points, m = diff.dpsi.shape
    if what == "mode":
        return np.concatenate([[k], m + np.arange(n_points) * m + k])
    return m + k * m + np.arange(m)


def linearised(fit: ChangeFit, rows: np.ndarray, lower: np.ndarray, upper: np.ndarray,
               space, n_freq: int, n_psi: int) -> ChangeFit | None:
    """Predict a fit without ``rows`` by one Gauss-Newton step from the fit on all data.

    dx = -(J_R^T J_R)^+ J_R^T r_R over the parameters no bound holds (module docstring),
    a parameter the step would take past a bound held there and the step taken again
    (the bounded problem's active set, at most ``len(x)`` times); the residual
    r_R + J_R dx and J_R stand for the refit's. None when no step stays within the bounds.
    """
    keep = np.ones(fit.residual.size, bool)
    keep[rows] = False
    r, J = fit.residual[keep], fit.jac[keep]
    active = fit.active.copy()
    for _ in range(fit.x.size):
        held = np.where(active < 0, lower, np.where(active > 0, upper, fit.x))
        dx = held - fit.x
        free = active == 0
        dx[free] = -np.linalg.lstsq(J[:, free], r + J @ dx, rcond=None)[0]
        x = fit.x + dx
        out = free & ((x < lower) | (x > upper))
        if not out.any():
            sol = LsqSolution(x, r + J @ dx, J, 0, active)
            return ChangeFit(sol, space.params(x), n_freq, n_psi)
        active[out & (x < lower)] = -1
        active[out & (x > upper)] = 1
    return None


def cook_distance(fit: ChangeFit, moved: ChangeFit, dof: int) -> float:
    """Cook's distance of the data a leave-out drops: D = dx^T J^T J dx / (p s^2).

    dx the predicted move of the parameters, J the Jacobian on all the data, p the free
    parameters, s^2 = max(RSS / dof, 1) (Cook 1977): how far the data left out pull the
    fit, in its own confidence region's units.
    """
    dx = moved.x - fit.x
    p = max(int(np.sum(fit.active == 0)), 1)
    s2 = max(fit.rss / max(dof, 1), 1.0)
    Jdx = fit.jac @ dx
    return float(Jdx @ Jdx) / (p * s2)


def _judged(fits: tuple[ChangeFit, ChangeFit], diff: Differences, space: ParamSpace,
            family: str, finding: Finding, false_alarm: float, predict,
            ) -> tuple[float, float, bool, Finding]:
    """(F, p, survives, finding) of H0's and the family's fits to the reduced changes."""
    null, fit = fits
    n = diff.n_data
    dof = max(n - (N_NULL + N_SEGMENT), 1)
    F, p = nested_f(null.rss, min(fit.rss, null.rss), N_SEGMENT, dof)
    cov = covariance(fit, max(n - N_NULL - N_PARAMS[family], 1))
    again = read_finding(family, fit, space, cov, predict)
    (a, b), (c, d) = finding.region_m, again.region_m
    survives = (is_significant(p, false_alarm) and again.kind == finding.kind
                and kind_supported(again) and a < d and c < b)
    return F, p, survives, again


def _predicted(diff: Differences, reduced: Differences, what: str, k: int,
               space: ParamSpace, fspace, family: str, null: ChangeFit, fit: ChangeFit,
               finding: Finding, false_alarm: float, predict):
    """Return the leave-out predicted to first order, or None.

    The prediction when it survives by far from data that are not influential (module
    docstring); None when it must be refitted.
    """
    rows = left_out_rows(diff, what, k)
    shape = (reduced.n_freq, reduced.dpsi.size)
    fits = (linearised(null, rows, space.bounds.lower, space.bounds.upper, space, *shape),
            linearised(fit, rows, fspace.lower(), fspace.upper(), fspace, *shape))
    if fits[0] is None or fits[1] is None:
        return None
    dof = diff.n_data - N_NULL - N_PARAMS[family]
    if max(cook_distance(null, fits[0], dof), cook_distance(fit, fits[1], dof)) > COOK_MAX:
        return None
    F, p, survives, again = _judged(fits, reduced, space, family, finding, false_alarm,
                                    predict)
    if survives and p < LINEAR_MARGIN * min(CLEAR_LEVEL, false_alarm):
        return F, p, survives, again
    return None


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

    def reduced(job):
        what, k = job
        if what == "mode":
            return diff.without_mode(k), np.delete(sigma, k)
        return diff.without_point(k), sigma

    fspace = family_space(space, family)
    current = all(np.allclose(residual_function(predict, diff, sp, sigma)(f.x), f.residual,
                              rtol=1e-9, atol=1e-12) for f, sp in ((null, space), (fit, fspace)))
    predicted = [None if not current else  # fitted with another noise: refit every leave-out
                 _predicted(diff, reduced(job)[0], *job, space, fspace, family, null, fit, finding,
                            false_alarm, predict) for job in jobs]

    def refit(job):
        d, s = reduced(job)
        fits = (fit_null(predict, d, space, s, x0=null.x),
                refit_family(predict, d, space, family, s, fit.x))
        return _judged(fits, d, space, family, finding, false_alarm, predict)

    todo = [job for job, guess in zip(jobs, predicted, strict=True) if guess is None]
    refits = dict(zip(todo, fork_map(refit, todo), strict=True))
    cases = []
    for (what, k), guess in zip(jobs, predicted, strict=True):
        F, p, ok, again = refits[(what, k)] if guess is None else guess
        label = mode_labels[k] if what == "mode" else \
            f"the point at {point_x_m[k] / IN_TO_M:.1f} in"
        cases.append(LeftOut(what, k, label, F, p, ok, dict(again.reading),
                             tuple(float(v) for v in again.region_m), guess is None))
    return Robustness(tuple(cases))
