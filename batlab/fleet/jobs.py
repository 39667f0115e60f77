"""One bat of a fleet study: drawn, written as a lab hands it over, inspected by `batlab`.

- false alarms (``false_alarm_row``): an unaltered bat with its job's nuisances and
  integrity slip, inspected statelessly;
- detection (``detection_rows``): a nuisance-rich bat registered once (its baseline), then
  every re-test of ``updating.simulate.detection.retests`` inspected through the registry.

A failure of the benchmark itself (the simulation, not batlab) is reported, not the end of
the run.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from batlab.fleet.runner import inspect_args, run_batlab, timed
from updating.simulate.detection import retests
from updating.simulate.field_fleet import draw_case, write_case, write_retest
from updating.simulate.meter import with_lab_records
from updating.simulate.nuisances import NUISANCES
from updating.simulate.scoring import verdict_row


def inspect_clean_bat(job: dict, retest_meta: bool) -> dict:
    """Draw, write and inspect one unaltered bat of a false-alarm plan.

    Parameters
    ----------
    job : dict
        A job of ``scoring.false_alarm_plan`` (group, serial, seed, nuisances, integrity).
    retest_meta : bool
        Pass retest.json to the inspection.

    Returns
    -------
    dict
        The result row (``scoring.verdict_row``) with the job's group.
    """
    rng = np.random.default_rng(job["seed"])
    case = draw_case(rng, "none", job["nuisances"], job["integrity"], job["serial"])
    with tempfile.TemporaryDirectory(prefix="batlab-fa-") as tmp:
        paths = write_case(case, tmp, seed=int(rng.integers(2**31)),
                           retest_meta_keys=None if retest_meta else ())
        out, err, dt = timed(inspect_args(paths))
    row = verdict_row(out, err, dt, case.truth)
    row["group"] = job["group"]
    return row


def false_alarm_row(job: dict, retest_meta: bool = True) -> dict:
    """Inspect one bat of a false-alarm plan; a failure of the simulation is an "error" row.

    Parameters
    ----------
    job : dict
        A job of ``scoring.false_alarm_plan``.
    retest_meta : bool
        Pass retest.json to the inspection.

    Returns
    -------
    dict
        The result row with the job's group (status "error" and the exception when the
        benchmark failed on that bat).
    """
    try:
        return inspect_clean_bat(job, retest_meta)
    except Exception as exc:  # the benchmark's own failure: report it, go on
        truth = {"serial": job["serial"], "kind": "none", "integrity": job["integrity"],
                 "expected": "inconclusive" if job["integrity"] else "not_altered"}
        row = verdict_row(None, f"{type(exc).__name__}: {exc}", 0.0, truth)
        row.update(status="error", group=job["group"])
        return row


def false_alarm_row_without_meta(job: dict) -> dict:
    """Inspect one bat of a false-alarm plan without its retest.json."""
    return false_alarm_row(job, retest_meta=False)


def detection_jobs(n_bats: int, seed: int, grid: list[tuple[float, float]], ratio: float,
                   kinds: list[str], no_retest_meta: bool, coherence: bool = False,
                   records: int | None = None) -> list[dict]:
    """Plan the detection study's bats: bat b has serial DET-b and seed ``seed * 100019 + b``.

    Parameters
    ----------
    n_bats : int
        Bats.
    seed : int
        The study's seed.
    grid, ratio, kinds
        As ``updating.simulate.detection.retests`` takes them.
    no_retest_meta : bool
        Do not pass retest.json.
    coherence : bool
        The tests' files carry their coherence (``nuisances.OPTIONAL_NUISANCES``): the noise
        measured, not estimated (docs/noise.md). The same bats either way.
    records : int or None
        What the lab records of the wood and the room, with N moisture readings a station
        (``updating.simulate.meter.with_lab_records``; 0: the dates and rooms alone): in
        meta.json and every re-test's retest.json (not with ``no_retest_meta``). The same
        bats either way: the records have their own random stream.

    Returns
    -------
    list of dict
        One job per bat.
    """
    nuisances = NUISANCES + (("coherence",) if coherence else ())
    return [{"serial": f"DET-{b + 1:03d}", "seed": seed * 100019 + b, "grid": grid,
             "ratio": ratio, "kinds": kinds, "no_retest_meta": no_retest_meta,
             "nuisances": nuisances, "records": records} for b in range(n_bats)]


def register_and_inspect(job: dict) -> list[dict]:
    """Register one bat and inspect all its re-tests through the registry.

    Parameters
    ----------
    job : dict
        A job of ``detection_jobs``.

    Returns
    -------
    list of dict
        One result row per re-test, in ``retests``' order; grid re-tests have
        ``truth["grid"]`` true.
    """
    rng = np.random.default_rng(job["seed"])
    case = draw_case(rng, "none", job.get("nuisances", NUISANCES), None, job["serial"])
    records = job.get("records")
    if records is not None:
        case = with_lab_records(case, job["seed"], records)
    rows = []
    n_grid = len(job["grid"])
    with tempfile.TemporaryDirectory(prefix="batlab-det-") as tmp:
        tmp = Path(tmp)
        keys = () if job["no_retest_meta"] else None
        paths = write_case(case, tmp, seed=int(rng.integers(2**31)), retest_meta_keys=keys,
                           registration=records is not None)
        db = tmp / "registry.sqlite"
        code, _, err = run_batlab(["register", "--profile", paths["profile"], "--meta",
                                   paths["meta"], "--baseline", paths["baseline"], "--db", db,
                                   "--json"])
        if code != 0:
            raise RuntimeError(f"{job['serial']}: register failed: {err}")
        for i, rt in enumerate(retests(case, job["grid"], job["ratio"], job["kinds"], rng)):
            p = dict(paths, retest=tmp / f"retest{i}.uff")
            p["retest_meta"] = write_retest(rt, p["retest"], tmp / f"retest{i}.json",
                                            int(rng.integers(2**31)), keys)
            out, err, dt = timed(inspect_args(p, serial=job["serial"], db=db))
            rows.append(verdict_row(out, err, dt, rt.truth))
    for i, r in enumerate(rows):
        r["truth"]["grid"] = 1 <= i <= n_grid
    return rows


def detection_rows(job: dict) -> list[dict]:
    """Run ``register_and_inspect``; no rows (the reason on stderr) when the benchmark fails.

    Parameters
    ----------
    job : dict
        A job of ``detection_jobs``.

    Returns
    -------
    list of dict
        The bat's result rows, or none.
    """
    try:
        return register_and_inspect(job)
    except Exception as exc:  # the benchmark's own failure: report it, go on
        print(f"  {job['serial']}: benchmark failed: {type(exc).__name__}: {exc}",
              file=sys.stderr)
        return []
