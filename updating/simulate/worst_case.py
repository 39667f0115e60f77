"""A worst-case search over nuisance vectors, and the tables of its results.

For one bat, ``search_worst`` looks for the nuisance vector (a point of the unit cube,
``updating.simulate.wide``) that makes the inspection's F largest, under a budget of
evaluations: random starts first, then a (1+1) evolution strategy from the best of them
(Rechenberg's 1/5 success rule; derivative-free, one evaluation per step, fit for budgets
smaller than the cube's dimension):

    x' = reflect(x + sigma z),  z_i ~ N(0, 1) on a random subset of about 3 coordinates
    (at least one), 0 elsewhere; reflect folds x' back into [0, 1];
    accept x' when F(x') > F(x): sigma <- min(0.5, 1.5 sigma), else sigma <- max(0.02,
    0.85 sigma)

(the step grows on success and shrinks on failure; the two factors balance at a success
rate of about 0.29). An evaluation without an F (a refusal, an inconclusive verdict before
the test) counts as -inf. Every evaluation is kept, with its phase, its vector, F and
status. The evaluation itself (bat -> files -> inspection) is a callable, so this module
does not depend on the stages that run it (``batlab.fleet.worst_case`` gives the real one).

``quantile_table`` and ``worst_table`` turn rows into the benchmark's markdown tables.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

SIGMA_MIN, SIGMA_MAX = 0.02, 0.5
GROW, SHRINK = 1.5, 0.85
MUTATED = 3.0
"""The expected number of coordinates a step moves."""
QUANTILES = (0.5, 0.9, 0.99, 0.999)


@dataclass(frozen=True)
class Evaluation:
    """One evaluated nuisance vector.

    Attributes
    ----------
    index : int
        Its place in the search (0-based).
    phase : str
        "start" (a random start) or "search" (a step of the strategy).
    unit : tuple of float
        The nuisance vector (unit cube).
    F : float
        The inspection's statistic (nan when it gave none).
    status : str
        The verdict's status (or "refused", "sim_error").
    row : dict
        What the evaluator returned besides (reasons, finding, settings, time).
    """

    index: int
    phase: str
    unit: tuple[float, ...]
    F: float
    status: str
    row: dict

    @property
    def score(self) -> float:
        """Return F, or -inf when there is none."""
        return self.F if np.isfinite(self.F) else -np.inf


@dataclass(frozen=True)
class SearchResult:
    """Every evaluation of one bat's search, in order."""

    evaluations: tuple[Evaluation, ...]

    def best(self, phase: str | None = None) -> Evaluation | None:
        """Return the evaluation of the largest F (of one phase if given); None if none."""
        ev = [e for e in self.evaluations if phase is None or e.phase == phase]
        finite = [e for e in ev if np.isfinite(e.F)]
        return max(finite, key=lambda e: e.F) if finite else None

    def count(self, status: str) -> int:
        """Return how many evaluations had ``status``."""
        return sum(e.status == status for e in self.evaluations)


def reflect(x: np.ndarray) -> np.ndarray:
    """Fold a point back into the unit cube (mirror at 0 and 1, period 2)."""
    y = np.mod(np.asarray(x, dtype=float), 2.0)
    return np.where(y > 1.0, 2.0 - y, y)


def search_worst(
    evaluate: Callable[[np.ndarray], tuple[float, str, dict]],
    starts: list[np.ndarray], budget: int, rng: np.random.Generator, sigma0: float = 0.2,
    on_evaluation: Callable[[Evaluation], None] | None = None,
) -> SearchResult:
    """Search for the nuisance vector of the largest F.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(unit) -> (F, status, row)`` for a unit-cube vector (F nan when none).
    starts : list of ndarray
        The random starts, evaluated first (at most ``budget`` of them).
    budget : int
        The evaluations in all.
    rng : numpy.random.Generator
        The strategy's steps.
    sigma0 : float
        The first step's size (unit-cube units).
    on_evaluation : callable or None
        Called with every evaluation as it is made (progress, saving).

    Returns
    -------
    SearchResult
        Every evaluation, starts first.
    """
    if not starts:
        raise ValueError("the search needs at least one start")
    done: list[Evaluation] = []

    def run(u: np.ndarray, phase: str) -> Evaluation:
        F, status, row = evaluate(u)
        ev = Evaluation(len(done), phase, tuple(float(v) for v in u),
                        float("nan") if F is None else float(F), status, row)
        done.append(ev)
        if on_evaluation is not None:
            on_evaluation(ev)
        return ev

    for u in starts[:budget]:
        run(np.asarray(u, dtype=float), "start")
    best = max(done, key=lambda e: e.score)
    x, sigma = np.array(best.unit), sigma0
    dim = x.size
    while len(done) < budget and dim:
        mask = rng.uniform(size=dim) < min(1.0, MUTATED / dim)
        mask[rng.integers(dim)] = True
        cand = run(reflect(x + sigma * mask * rng.standard_normal(dim)), "search")
        if cand.score > best.score:
            best, x, sigma = cand, np.array(cand.unit), min(SIGMA_MAX, GROW * sigma)
        else:
            sigma = max(SIGMA_MIN, SHRINK * sigma)
    return SearchResult(tuple(done))


def _fmt(v) -> str:
    """Format a number for a table cell (- for none)."""
    if v is None or not np.isfinite(v):
        return "-"
    return f"{v:.3g}" if abs(v) < 1e4 else f"{v:.3e}"


def quantile_table(rows: list[dict], group_key: str = "group") -> str:
    """Tabulate F's quantiles and the statuses per group of rows (markdown).

    Parameters
    ----------
    rows : list of dict
        Each with ``group_key``, ``F`` (None or nan when none), ``p`` and ``status``.
    group_key : str
        The key that names a row's group (first-seen order).

    Returns
    -------
    str
        One line per group: bats, F at 50, 90, 99, 99.9 % (linear interpolation between
        order statistics; with few bats the upper ones are the largest F), the largest F, the
        smallest p, and the counts of altered, inconclusive and refused or failed.
    """
    groups: dict[str, list[dict]] = {}
    for r in rows:
        groups.setdefault(r[group_key], []).append(r)
    head = ("| nuisances | bats | F 50 % | F 90 % | F 99 % | F 99.9 % | largest F | smallest p "
            "| altered | inconclusive | refused/failed |\n" + "|---" * 11 + "|")
    lines = [head]
    for g, rs in groups.items():
        F = np.array([r["F"] for r in rs if r.get("F") is not None and np.isfinite(r["F"])])
        q = np.quantile(F, QUANTILES) if F.size else [None] * len(QUANTILES)
        ps = [r["p"] for r in rs if r.get("p") is not None]
        alt = sum(r["status"] == "altered" for r in rs)
        inc = sum(r["status"] == "inconclusive" for r in rs)
        other = sum(r["status"] not in ("altered", "inconclusive", "not_altered") for r in rs)
        lines.append(f"| {g} | {len(rs)} | " + " | ".join(_fmt(v) for v in q)
                     + f" | {_fmt(F.max() if F.size else None)} | "
                     f"{_fmt(min(ps)) if ps else '-'} | {alt} | {inc} | {other} |")
    return "\n".join(lines)


def worst_table(bats: list[dict]) -> str:
    """Tabulate each bat's search (markdown).

    Parameters
    ----------
    bats : list of dict
        Each with ``seed``, ``handle`` and ``evaluations`` (rows with ``phase``, ``F``,
        ``status``).

    Returns
    -------
    str
        Per bat: evaluations, the largest F of the random starts and of the whole search,
        the status at the largest F, and the counts of altered and inconclusive; then the
        F quantiles of every random start against the bats' searched largest F.
    """
    lines = ["| bat | handle | evaluations | largest F, random starts | largest F, searched "
             "| status there | altered | inconclusive |", "|---|---|---|---|---|---|---|---|"]
    starts, worst = [], []
    for b in bats:
        ev = b["evaluations"]
        fin = [e for e in ev if e.get("F") is not None and np.isfinite(e["F"])]
        st = [e["F"] for e in fin if e["phase"] == "start"]
        starts += st
        top = max(fin, key=lambda e: e["F"]) if fin else None
        if top is not None:
            worst.append(top["F"])
        lines.append(f"| {b['seed']} | {b['handle']} | {len(ev)} | "
                     f"{_fmt(max(st) if st else None)} | {_fmt(top['F'] if top else None)} | "
                     f"{top['status'] if top else '-'} | "
                     f"{sum(e['status'] == 'altered' for e in ev)} | "
                     f"{sum(e['status'] == 'inconclusive' for e in ev)} |")
    if starts:
        q = np.quantile(starts, QUANTILES)
        lines.append("")
        lines.append(f"random starts ({len(starts)}): F at 50/90/99/99.9 % "
                     + " / ".join(_fmt(v) for v in q) + f"; largest {_fmt(max(starts))}")
    if worst:
        lines.append(f"searched worst per bat ({len(worst)}): median {_fmt(np.median(worst))}, "
                     f"largest {_fmt(max(worst))}")
    return "\n".join(lines)
