"""Wide-nuisance bats through the real path: one evaluation, an ablation row, a bat's search.

An evaluation (``evaluate_wide``) makes the bat of a seed under a nuisance vector
(``updating.simulate.wide``), writes it as the lab's files and runs the real stateless path
(``batlab.fleet.cache.build_case``: reading, modal fits, calibration; then ``score_one``: the
inspection, without the MSSO map, which does not change the verdict). With a cache folder the
built inputs are kept (``<seed>_<hash of the settings>.pkl``) and only the inspection runs
again on a later call: for re-scoring after a change of the inspection alone (not of the
modal fit or the calibration). ``ablation_row``, ``band_edge_row`` and ``search_bat`` are the
benchmark's jobs (module-level, for ``fleet_map``).
"""

from __future__ import annotations

import hashlib
import json
import pickle
import sys
from pathlib import Path

import numpy as np

from batlab.fleet.cache import build_case, score_one, with_records
from updating.simulate import wide
from updating.simulate.worst_case import Evaluation, search_worst

KEEP = ("status", "F", "p", "reasons", "finding", "candidate", "weight_change_rel", "time_s",
        "kind", "expected")
"""The inspection row's keys an evaluation keeps."""


def _key(seed: int, settings: dict, with_meta: bool, coherence: bool) -> str:
    """Return a cache file's name for a bat under settings."""
    text = json.dumps([seed, settings, with_meta] + ([True] if coherence else []),
                      sort_keys=True, default=float)
    return f"{seed}_{hashlib.sha256(text.encode()).hexdigest()[:16]}.pkl"


def _built(seed: int, settings: dict, with_meta: bool, cache: Path | None,
           coherence: bool = False) -> dict:
    """Build a wide bat's inspection inputs (from the cache when there)."""
    path = None if cache is None else Path(cache) / _key(seed, settings, with_meta, coherence)
    if path is not None and path.exists():
        return pickle.loads(path.read_bytes())
    try:
        case = wide.wide_case(seed, settings, coherence=coherence)
    except ValueError as exc:
        return {"seed": seed, "kind": "none", "integrity": None,
                "error": ("sim_error", str(exc))}
    bat = build_case(case, seed, with_meta)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        tmp.write_bytes(pickle.dumps(bat))
        tmp.replace(path)
    return bat


def evaluate_wide(seed: int, unit: np.ndarray, nuisances, with_meta: bool = True,
                  cache: Path | None = None, coherence: bool = False,
                  records: int | None = None) -> tuple[float | None, str, dict]:
    """Inspect the bat of ``seed`` under the nuisance vector ``unit``.

    Parameters
    ----------
    seed : int
        The bat.
    unit : ndarray
        A unit-cube point over ``wide.space(nuisances)``.
    nuisances : iterable of str
        The wide nuisances that are on.
    with_meta : bool
        Write and pass retest.json.
    cache : Path or None
        A folder keeping the built inspection inputs.
    coherence : bool
        The tests' files carry their coherence (docs/noise.md).
    records : int or None
        The lab's records of this bat's wood and rooms (``cache.with_records`` of its wide
        case): both tests' dates and rooms and N moisture readings a station; None: none.

    Returns
    -------
    F : float or None
        The verdict's statistic.
    status : str
        The verdict's status ("sim_error" when the simulator cannot make the bat,
        "refused" when the path refuses it).
    row : dict
        The inspection row's main keys (``KEEP``), the settings and what they made (the
        truth's ``drawn``).
    """
    return evaluate_settings(seed, wide.settings_of(unit, nuisances), with_meta, cache,
                             coherence, records)


def evaluate_settings(seed: int, settings: dict, with_meta: bool = True,
                      cache: Path | None = None, coherence: bool = False,
                      records: int | None = None) -> tuple[float | None, str, dict]:
    """Inspect the bat of ``seed`` under physical ``settings`` (``evaluate_wide``'s result)."""
    bat = _built(seed, settings, with_meta, cache, coherence)
    if records is not None and "error" not in bat:
        bat = with_records(bat, records, wide.wide_case(seed, settings, coherence=coherence))
    full = score_one(bat, with_map=False)
    row = {k: full[k] for k in KEEP if k in full}
    row["settings"] = settings
    drawn = (bat.get("truth") or {}).get("drawn", {})
    row["made"] = {k: v for k, v in drawn.items() if k != "wide"}
    F = full.get("F")
    return (None if F is None else float(F)), full["status"], row


def band_edge_row(job: dict) -> dict:
    """Inspect one ``wide.band_edge_case`` (job: seed, with_meta, cache): a row as ablation's.

    Group "band_edge_case"; a seed the constructor refuses gives status "sim_error".
    """
    seed = job["seed"]
    out = {"group": "band_edge_case", "seed": seed}
    try:
        case = wide.band_edge_case(seed)
    except ValueError as exc:
        return {**out, "status": "sim_error", "F": None, "reasons": [str(exc)]}
    F, status, row = evaluate_settings(seed, case.truth["drawn"]["wide"],
                                       job.get("with_meta", True), job.get("cache"),
                                       job.get("coherence", False))
    return {**out, **row, "F": F, "status": status}


def ablation_row(job: dict) -> dict:
    """Inspect one bat of an ablation group.

    Parameters
    ----------
    job : dict
        group, seed, nuisances, with_meta and cache (folder or None).

    Returns
    -------
    dict
        group, seed, nuisances, the vector (``unit``) and ``evaluate_wide``'s row with F
        and status.
    """
    nuis = tuple(job["nuisances"])
    unit = wide.fleet_start(job["seed"], nuis)
    F, status, row = evaluate_wide(job["seed"], unit, nuis, job.get("with_meta", True),
                                   job.get("cache"), job.get("coherence", False))
    return {"group": job["group"], "seed": job["seed"], "nuisances": list(nuis),
            "unit": [float(v) for v in unit], **row, "F": F, "status": status}


def search_bat(job: dict) -> dict:
    """Search one bat's nuisances for its largest F (``worst_case.search_worst``).

    Parameters
    ----------
    job : dict
        seed, handle, nuisances, budget, starts (random starts among the budget),
        with_meta, cache (folder or None) and log (a JSON-lines file each evaluation is
        appended to as it is made, or None).

    Returns
    -------
    dict
        seed, handle, nuisances, kind (the handle) and status (the largest F, for the
        progress lines) and ``evaluations``: one row per evaluation (index, phase, unit, F,
        status and ``evaluate_wide``'s row).
    """
    seed, nuis = job["seed"], tuple(job["nuisances"])
    rng = np.random.default_rng([seed, 1])
    starts = [wide.random_unit(rng, nuis) for _ in range(max(1, job["starts"]))]
    log = job.get("log")

    def evaluate(u):
        return evaluate_wide(seed, u, nuis, job.get("with_meta", True), job.get("cache"),
                             job.get("coherence", False), job.get("records"))

    def note(ev: Evaluation) -> None:
        F = "-" if not np.isfinite(ev.F) else f"{ev.F:.2f}"
        print(f"  bat {seed} {ev.phase} {ev.index + 1}/{job['budget']}: F {F} {ev.status}",
              file=sys.stderr, flush=True)
        if log:
            with open(log, "a") as fh:
                fh.write(json.dumps(evaluation_row(seed, job["handle"], ev), default=float)
                         + "\n")

    res = search_worst(evaluate, starts, job["budget"], np.random.default_rng([seed, 6]),
                       on_evaluation=note)
    top = res.best()
    return {"seed": seed, "handle": job["handle"], "nuisances": list(nuis),
            "kind": job["handle"], "status": f"largest F {top.F:.3g}" if top else "no F",
            "evaluations": [evaluation_row(seed, job["handle"], e) for e in res.evaluations]}


def evaluation_row(seed: int, handle: str, ev: Evaluation) -> dict:
    """Return one evaluation as a JSON-able row (seed, handle, index, phase, unit, F, ...)."""
    return {"seed": seed, "handle": handle, "index": ev.index, "phase": ev.phase,
            "unit": list(ev.unit), **ev.row,
            "F": None if not np.isfinite(ev.F) else ev.F, "status": ev.status}
