"""Fleet bats through the real stateless path, and cached for re-scoring the inspection alone.

``field_row`` draws a nuisance-rich fleet bat (``updating.simulate.field_fleet.draw_case``),
writes it as the lab's files and inspects it through ``batlab.pipeline.inspect_files``;
``build_one`` runs the same reading, modal fits and calibration once and keeps what
``updating.inspect.run.inspect`` takes, and ``score_one`` runs only the inspection on it (a
change of H0, H1 or the decision's gates does not touch the fits). Used by
``benchmarks/bench_inspect_field.py`` and ``benchmarks/inspect_cache.py``, and by the tests.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import batlab.pipeline as pipeline
from updating.inspect.retest_meta import RetestConditions, conditions_from_dict
from updating.inspect.run import inspect
from updating.simulate.alterations import KINDS
from updating.simulate.field_fleet import draw_case, write_case
from updating.simulate.integrity import INTEGRITY
from updating.simulate.meter import lab_records
from updating.simulate.nuisances import NUISANCES


def field_row(seed: int, kind: str, integrity: str | None, with_meta: bool,
              registration: bool = False) -> dict:
    """Draw, write and inspect one fleet bat through the stateless path; its scored row."""
    rng = np.random.default_rng(seed)
    row = {"seed": seed, "kind": kind, "integrity": integrity}
    with tempfile.TemporaryDirectory(prefix="batlab-field-") as tmp:
        try:
            case = draw_case(rng, kind, integrity=integrity, serial=f"F-{seed}")
            paths = write_case(case, tmp, seed, retest_meta_keys=None if with_meta else [],
                               registration=registration)
        except ValueError as exc:  # the simulator cannot make this draw: not counted
            row.update(status="sim_error", reasons=[str(exc)])
            return row
        row["expected"] = case.expected
        t0 = time.perf_counter()
        try:
            res = pipeline.inspect_files(paths["profile"], paths["meta"], paths["baseline"],
                                         paths["retest"], 0.01,
                                         retest_meta_path=paths["retest_meta"])
        except ValueError as exc:
            row.update(status="refused", reasons=[str(exc)],
                       time_s=time.perf_counter() - t0)
            return row
        row["time_s"] = time.perf_counter() - t0
    return score_verdict(row, case.meta["serial"], res.verdict, kind, case.truth)


def score_verdict(row: dict, serial: str, verdict, kind: str, truth: dict) -> dict:
    """Score a verdict against the truth of its fleet bat.

    ``row`` with the verdict's status, reasons, F test, candidate core and finding, and for a
    cored bat called altered and read as a core the reading's errors against ``truth`` (start
    in, diameter relative, fill ratio absolute and relative, and whether the fill is within
    target).
    """
    out = pipeline.contract_dict(serial, verdict)
    fit = verdict.details.fit
    row.update(status=out["status"], reasons=out["reasons"], F=verdict.statistic,
               p=None if fit is None else fit.p_value,
               F_fit=None if fit is None else fit.F_fit,
               weight_change_rel=None if fit is None else fit.weight_change_rel,
               null_fit=None if fit is None else fit.null_fit,
               plug_m=None if fit is None else fit.plug_m,
               candidate=None if fit is None else fit.candidate_core.to_json_dict(),
               finding=out["finding"])
    t = truth
    if (kind != "none" and out["status"] == "altered" and t.get("core_diameter_in")
            and out["core_diameter_in"] is not None):
        row["start_err_in"] = out["region_in"][0] - t["region_in"][0]
        row["d_err_rel"] = out["core_diameter_in"] / t["core_diameter_in"] - 1
        r_true = t["fill_density_ratio"]
        row["fill_err"] = out["fill_density_ratio"] - r_true
        row["fill_err_rel"] = row["fill_err"] / r_true if r_true > 0 else None
        row["fill_ok"] = bool(abs(row["fill_err"]) <= (0.25 * r_true if r_true > 0 else 0.1))
    return row


def jobs(clean: int, altered: int, integrity: int, seed: int) -> list[tuple[int, str, str | None]]:
    """Lay out the bats: (seed, kind, integrity) as ``bench_inspect_field`` lays them."""
    js = [("none", None)] * clean + [(KINDS[i % len(KINDS)], None) for i in range(altered)]
    js += [("none", g) for _ in range(integrity) for g in INTEGRITY]
    return [(seed + i, k, g) for i, (k, g) in enumerate(js)]


def path_of(folder: Path, seed: int, kind: str, integ: str | None) -> Path:
    """Return where a cached bat is kept: FOLDER/<seed>_<kind>[_<slip>].pkl."""
    return folder / f"{seed}_{kind}{'_' + integ if integ else ''}.pkl"


def build_one(seed: int, kind: str, integ: str | None, with_meta: bool = True,
              nuisances=NUISANCES, registration: bool = False) -> dict:
    """Build everything ``inspect`` needs for this bat, and its truth (or an error)."""
    rng = np.random.default_rng(seed)
    try:
        case = draw_case(rng, kind, nuisances, integrity=integ, serial=f"F-{seed}")
    except ValueError as exc:
        return {"seed": seed, "kind": kind, "integrity": integ,
                "error": ("sim_error", str(exc))}
    out = build_case(case, seed, with_meta, registration)
    if "error" not in out:
        out["nuisances"] = list(nuisances)
    return out


def build_case(case, seed: int, with_meta: bool = True, registration: bool = False) -> dict:
    """Write a drawn case's files and run the real path up to the inspection's inputs.

    Parameters
    ----------
    case : FieldCase
        The bat (``field_fleet.draw_case``, ``wide.wide_case``, ...).
    seed : int
        Its seed (the FRF noise seeds are ``write_case``'s from it).
    with_meta : bool
        Write retest.json.
    registration : bool
        meta.json records the baseline's temperature and accelerometer mass.

    Returns
    -------
    dict
        What ``score_one`` takes (seed, kind, integrity, truth, expected, the calibrated
        reference, both tests' modes, the conditions), or with ``error`` (kind, reason).
    """
    out: dict = {"seed": seed, "kind": case.kind, "integrity": case.integrity,
                 "truth": case.truth, "expected": case.expected}
    with tempfile.TemporaryDirectory(prefix="batlab-cache-") as tmp:
        try:
            paths = write_case(case, tmp, seed, retest_meta_keys=None if with_meta else [],
                               registration=registration)
        except ValueError as exc:
            out["error"] = ("sim_error", str(exc))
            return out
        try:
            cond = pipeline.read_conditions(paths["retest_meta"])
            bat = pipeline.stateless_case(paths["profile"], paths["meta"], paths["baseline"],
                                          paths["retest"])
        except ValueError as exc:
            out["error"] = ("refused", str(exc))
            return out
    out.update(registration=registration, serial=bat.serial,
               profile=bat.profile, reference=bat.reference,
               baseline=bat.baseline.modes, retest=bat.retest.modes, conditions=cond,
               registered=bat.registered)
    return out


def _redrawn(bat: dict):
    """Return the cached bat's case, re-drawn from its seed (which makes the same bat)."""
    return draw_case(np.random.default_rng(bat["seed"]), bat["kind"],
                     bat.get("nuisances", NUISANCES), integrity=bat["integrity"],
                     serial=f"F-{bat['seed']}")


def registered_conditions(bat: dict) -> RetestConditions:
    """Return the bat's registration with the baseline's temperature and accelerometer mass.

    As if meta.json had recorded them (``FieldCase.registration_conditions``).
    """
    extra = conditions_from_dict(_redrawn(bat).registration_conditions, "meta.json")
    return replace(bat["registered"], sensor_mass_kg=extra.sensor_mass_kg,
                   temperature_c=extra.temperature_c)


RECORD_FIELDS = ("tested_on", "moisture", "humidity_pct", "conditioned_h")
"""What ``with_records`` adds to both tests' conditions."""


def with_records(bat: dict, per_station: int, case=None) -> dict:
    """Return the cached bat with the lab's records of its wood and rooms.

    ``updating.simulate.meter.lab_records`` of ``case`` (default: the bat re-drawn from its
    seed): both tests' dates and rooms, and ``per_station`` moisture readings at each station
    (0: none), added to the registration's and the re-test's conditions (a bat cached without
    retest.json gains one holding only these). The modes do not depend on them, so the cache
    serves both.
    """
    records = lab_records(_redrawn(bat) if case is None else case, bat["seed"], per_station)
    out = dict(bat)
    for key, where in (("registered", "registration"), ("conditions", "retest")):
        got = conditions_from_dict(records[where], f"{where} records")
        out[key] = replace(bat[key] or RetestConditions(),
                           **{f: getattr(got, f) for f in RECORD_FIELDS})
    return out


def score_one(bat: dict, false_alarm: float = 0.01, registration: bool = False,
              with_map: bool = True, records: int | None = None) -> dict:
    """Run the inspection alone on a cached bat: ``field_row``'s row.

    With ``registration``: meta.json's baseline temperature and accelerometer mass given;
    ``with_map`` False skips the MSSO element map (the verdict is the same); ``records``
    N: both tests' dates, rooms and N moisture readings a station (``with_records``; 0:
    dates and rooms alone; None: none).
    """
    row = {"seed": bat["seed"], "kind": bat["kind"], "integrity": bat["integrity"]}
    if "error" in bat:
        row.update(status=bat["error"][0], reasons=[bat["error"][1]])
        return row
    row["expected"] = bat["expected"]
    if registration and not bat.get("registration"):
        bat = dict(bat, registered=registered_conditions(bat))
    if records is not None:
        bat = with_records(bat, records)
    t0 = time.perf_counter()
    try:
        v = inspect(bat["profile"], bat["reference"], bat["baseline"], bat["retest"],
                    false_alarm, bat["conditions"], bat["registered"], with_map=with_map)
    except ValueError as exc:
        row.update(status="refused", reasons=[str(exc)], time_s=time.perf_counter() - t0)
        return row
    row["time_s"] = time.perf_counter() - t0
    return score_verdict(row, bat["serial"], v, bat["kind"], bat["truth"])
