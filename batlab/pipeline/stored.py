"""Stored inspections: an inspection stored, and read back (provenance, report inputs, export).

The MSSO element map is evidence a report draws, not part of the verdict: an inspection
without a report (``batlab inspect --serial`` without ``-o``/``--plots``, ``batlab fleet
inspect``) skips it, and a report of such a stored verdict judges the stored tests again with
the map (``with_element_map``). It draws that map only when the second judgement gives the
stored status and statistic, else it says why there is no map.
"""

from __future__ import annotations

from dataclasses import asdict, replace
from pathlib import Path

import sqlalchemy as sa

from batlab import registry as reg
from batlab.pipeline.chance import calibration_for
from batlab.pipeline.files import Progress, file_sha256, quiet
from batlab.pipeline.inspection import InspectionCase, InspectionResult, judge
from batlab.pipeline.records import ReportInputs, same_judgement, verdict_record
from batlab.pipeline.registered import registration_case
from batlab.registry.row_check import verdict_differences
from batlab.version import code_version
from updating.inspect.retest_meta import RetestConditions
from updating.model.calipers import CaliperSurvey, make_survey

__all__ = [
    "already_inspected", "bat_inspection_number", "history_table", "note_report",
    "provenance", "report_inputs", "store_inspection", "stored_bat", "stored_report_inputs",
]


EXPORT_COLUMNS = [
    "serial", "species", "inspection", "inspected_at", "status", "altered",
    "region_start_in", "region_end_in", "core_diameter_in", "fill_density_ratio",
    "p_value", "false_alarm_rate", "chance", "chance_source", "calibration_record",
    "false_alarm_measured", "false_alarm_upper95", "reasons", "retest_file", "retest_sha256",
    "baseline_sha256", "registration_record", "verdict_record", "verdict_record_sha256",
    "report_path", "code"]
"""The columns of `batlab export`, in order."""


def survey_dict(survey: CaliperSurvey) -> dict:
    """Return a re-test profile as stored with its inspection (SI lists)."""
    return {"x_m": survey.x_m.tolist(), "angle_deg": survey.angle_deg.tolist(),
            "diameter_m": survey.diameter_m.tolist(), "angles_given": survey.angles_given}


def survey_from_dict(d: dict) -> CaliperSurvey:
    """Return a stored re-test profile (``survey_dict``'s inverse)."""
    return make_survey(d["x_m"], d["angle_deg"], d["diameter_m"], "stored re-test profile",
                       bool(d.get("angles_given", True)))


def store_inspection(
    conn: sa.Connection, result: InspectionResult, retest_path, false_alarm: float = 0.01,
    retest_meta: bool = False, once: bool = False,
) -> reg.Inspection:
    """Record an inspection of a registered bat.

    Its verdict, a copy of the re-test file, the registration it was judged against and the
    inputs its report needs.

    Parameters
    ----------
    conn : sa.Connection
        The registry.
    result : InspectionResult
        The inspection.
    retest_path : str or os.PathLike
        The re-test file (its bytes as judged are stored when the result kept them).
    false_alarm : float
        The decision's false-alarm rate.
    retest_meta : bool
        Whether a retest.json gave the re-test's conditions (kept in the inputs, with the
        conditions themselves, SI, so that a report can judge the tests again). A re-test
        profile judged with it (``result.survey``) is kept in them likewise.
    once : bool
        Store it unless the same re-test is stored already (``already_inspected``, asked
        inside the storing transaction): then ``registry.AlreadyStored`` is raised with the
        stored inspection. Two processes inspecting one re-test at once thus store it once.

    Returns
    -------
    Inspection
        The stored inspection.
    """
    path = Path(retest_path)
    content = result.retest_content if result.retest_content is not None else \
        path.read_bytes()
    record = verdict_record(result.serial, result.verdict, result.stated)
    inputs = {"false_alarm": float(false_alarm), "batlab_version": record["code"],
              "retest_meta": bool(retest_meta)}
    if retest_meta and result.conditions is not None:
        inputs["retest_conditions"] = asdict(result.conditions)
    if result.survey is not None:
        inputs["retest_profile"] = survey_dict(result.survey)
    def same_as(c: sa.Connection) -> reg.Inspection | None:
        return already_inspected(c, result.serial, path, false_alarm)

    return reg.add_inspection(conn, result.serial, record, path.name, content,
                              reference_seq=result.reference_seq, inputs=inputs,
                              same_as=same_as if once else None)


def already_inspected(
    conn: sa.Connection, serial: str, retest_path, false_alarm: float = 0.01,
) -> reg.Inspection | None:
    """Find the bat's latest stored inspection of this very re-test file, if any.

    The same file (SHA-256) against the bat's current baseline at the same false-alarm rate,
    inspected without a retest.json (whose conditions are not stored to compare) and without
    a re-test profile.

    Parameters
    ----------
    conn : sa.Connection
        The registry.
    serial : str
        The bat's serial number.
    retest_path : str or os.PathLike
        The re-test file.
    false_alarm : float
        The decision's false-alarm rate.

    Returns
    -------
    Inspection or None
        The stored inspection, None when this file was not inspected yet.
    """
    bat = reg.get_bat(conn, serial)
    sha = file_sha256(retest_path)
    same = [i for i in reg.history(conn, serial)
            if i.retest_sha256 == sha and i.baseline_sha256 == bat.baseline_sha256
            and (i.inputs or {}).get("false_alarm", 0.01) == float(false_alarm)
            and not (i.inputs or {}).get("retest_meta", False)
            and "retest_profile" not in (i.inputs or {})]
    return same[-1] if same else None


def stored_bat(conn: sa.Connection, stored: reg.Inspection) -> reg.BatRecord:
    """Return the registration a stored inspection was judged against."""
    return reg.bat_as_registered(conn, stored.reference_seq)


def note_report(conn: sa.Connection, stored: reg.Inspection, path: str) -> None:
    """Record where the inspection's report was written."""
    reg.set_report_path(conn, stored.id, path)


def bat_inspection_number(conn: sa.Connection, stored: reg.Inspection) -> int:
    """Return an inspection's number among its bat's own (1 for its first).

    The registry numbers inspections across all bats (``Inspection.id``); a bat's first
    inspection is its inspection 1 whatever that id.
    """
    return 1 + [r.id for r in reg.history(conn, stored.serial)].index(stored.id)


def provenance(
    conn: sa.Connection | None = None, stored: reg.Inspection | None = None,
    baseline_sha256: str | None = None, retest_sha256: str | None = None,
) -> dict:
    """Gather the facts a report prints to be verified.

    Parameters
    ----------
    conn : sa.Connection or None
        The registry (for a stored inspection).
    stored : Inspection or None
        The stored inspection: its number, time and custody records (the verdict's and
        the registration's).
    baseline_sha256, retest_sha256 : str or None
        The files' hashes of a stateless inspection.

    Returns
    -------
    dict
        The version, file hashes and, for a stored inspection, its records.
    """
    out = {"batlab_version": code_version(), "baseline_sha256": baseline_sha256,
           "retest_sha256": retest_sha256}
    if stored is not None and conn is not None:
        out.update({"inspection_id": stored.id, "inspected_at": stored.inspected_at,
                    "baseline_sha256": stored.baseline_sha256,
                    "retest_sha256": stored.retest_sha256,
                    "verdict_record": stored.record_seq, "verdict_record_sha256":
                    stored.record_sha256,
                    "verdict_sha256": reg.custody_record(conn, stored.record_seq).content_sha256,
                    "chain_head": reg.head(conn),
                    "bat_inspection": bat_inspection_number(conn, stored)})
        if stored.reference_seq is not None:
            ref = reg.custody_record(conn, stored.reference_seq)
            out.update({"reference_record": ref.seq, "reference_record_sha256":
                        ref.record_sha256})
        if stored.inputs:
            out["batlab_version"] = stored.inputs.get("batlab_version", code_version())
    return out


def report_inputs(result: InspectionResult, meta: dict, prov: dict) -> ReportInputs:
    """Return a fresh inspection's report inputs (the verdict as it is stored).

    Parameters
    ----------
    result : InspectionResult
        The inspection.
    meta : dict
        The bat's meta.json.
    prov : dict
        Its provenance (``provenance``).

    Returns
    -------
    ReportInputs
        What the report is drawn from.
    """
    return ReportInputs(result.serial, result.profile, result.reference, result.baseline,
                        result.retest, verdict_record(result.serial, result.verdict,
                                                      result.stated), meta, prov,
                        None if result.conditions is None else asdict(result.conditions))


def _stored_inspection(conn: sa.Connection, serial: str,
                       inspection_id: int | None) -> reg.Inspection:
    """Find the bat's inspection ``inspection_id`` (None: its latest) that kept its files."""
    rows = reg.history(conn, serial)
    if not rows:
        raise ValueError(f"bat {serial!r} has no inspection in the registry")
    if inspection_id is None:
        stored = rows[-1]
    else:
        match = [r for r in rows if r.id == inspection_id]
        if not match:
            raise ValueError(f"inspection #{inspection_id} is not one of bat {serial!r}'s "
                             f"(its inspections: {', '.join(str(r.id) for r in rows)})")
        stored = match[0]
    if stored.reference_seq is None:
        raise ValueError(f"inspection #{stored.id} of {serial!r} predates registry schema 3: "
                         "its re-test file and model were not kept, its report cannot be "
                         "rebuilt")
    return stored


def stored_case(
    conn: sa.Connection, serial: str, inspection_id: int | None = None,
    progress: Progress = quiet,
) -> tuple[reg.Inspection, reg.BatRecord, InspectionCase]:
    """Read a past inspection's case back from the registry alone.

    Its row is checked against its signed verdict record first
    (``registry.row_check.verdict_differences``): a verdict changed after it was stored is
    refused, saying what differs. The registration it was judged against (custody record,
    also after ``register --replace``) and both test files read back (checksums verified) and
    refitted (``registered.registration_case``).

    Parameters
    ----------
    conn : sa.Connection
        The registry.
    serial : str
        The bat's serial number.
    inspection_id : int or None
        The inspection; None for the bat's latest.
    progress : Progress
        Receives one-line messages.

    Returns
    -------
    stored : Inspection
        The stored inspection.
    bat : BatRecord
        The registration it was judged against.
    case : InspectionCase
        Its case, both tests fitted.
    """
    stored = _stored_inspection(conn, serial, inspection_id)
    differs = verdict_differences(conn, stored.id, stored.record_seq)
    if differs:
        raise ValueError(f"inspection #{stored.id} of {serial!r} differs from its signed "
                         f"verdict record #{stored.record_seq} ({'; '.join(differs)}): changed "
                         "after it was stored; no page is drawn from it (`batlab registry "
                         "check` lists every change)")
    bat = reg.bat_as_registered(conn, stored.reference_seq)
    base_name, base_bytes = reg.stored_file(conn, stored.baseline_sha256,
                                            f"inspection #{stored.id} baseline")
    re_name, re_bytes = reg.stored_file(conn, stored.retest_sha256,
                                        f"inspection #{stored.id} re-test")
    case = registration_case(bat, serial, (bat.baseline_name or base_name, base_bytes),
                             (stored.retest_name or re_name, re_bytes),
                             refit_baseline=True, progress=progress, fresh=False)
    survey = (stored.inputs or {}).get("retest_profile")
    if survey is not None:  # judged with the re-test's caliper profile: judged again with it
        case = replace(case, survey=survey_from_dict(survey))
    return stored, bat, case


def stored_report_inputs(
    conn: sa.Connection, serial: str, inspection_id: int | None = None,
    progress: Progress = quiet,
) -> ReportInputs:
    """Rebuild a past inspection's report inputs from the registry alone.

    The verdict as stored and its case read back (``stored_case``), with its element map
    (``with_element_map``).

    Parameters
    ----------
    conn : sa.Connection
        The registry.
    serial : str
        The bat's serial number.
    inspection_id : int or None
        The inspection; None for the bat's latest.
    progress : Progress
        Receives one-line messages.

    Returns
    -------
    ReportInputs
        What the report is drawn from.
    """
    stored, bat, case = stored_case(conn, serial, inspection_id, progress)
    inputs = ReportInputs(serial, case.profile, case.reference, case.baseline, case.retest,
                          stored.verdict, bat.meta, provenance(conn, stored=stored),
                          (stored.inputs or {}).get("retest_conditions"))
    decided = (stored.verdict.get("details") or {}).get("decided_on") == "calibration"
    calibration = calibration_for(conn, case.model)[0] if decided else None
    return with_element_map(inputs, case, stored.inputs or {}, progress, calibration)


def with_element_map(inputs: ReportInputs, case: InspectionCase, stored_inputs: dict,
                     progress: Progress = quiet, calibration=None) -> ReportInputs:
    """Return a stored inspection's report inputs with its MSSO element map (module docstring).

    Parameters
    ----------
    inputs : ReportInputs
        The stored verdict, the registration it was judged against and both tests refitted.
    case : InspectionCase
        The same, as the method judges it (``stored_case``).
    stored_inputs : dict
        The inspection's stored inputs (false-alarm rate, retest.json's conditions).
    progress : Progress
        Receives one-line messages.
    calibration : StoredCalibration or None
        The calibration the stored verdict was decided on (its ``decided_on``), which the
        second judgement decides on too; None: the nominal chance.

    Returns
    -------
    ReportInputs
        ``inputs`` as they were when the stored verdict holds a map (or the reason it has
        none, or no test to map); else with the map of a second judgement (and
        ``map_judged_again``, which the report states), or the reason there is none, in a
        copy of the verdict (the stored record is unchanged).
    """
    v = inputs.verdict
    details = v.get("details") or {}
    if "statistic" not in details or details.get("msso"):
        return inputs
    if stored_inputs.get("retest_meta") and "retest_conditions" not in stored_inputs:
        emap = {"error": "this inspection's retest.json was not stored with it, so its tests "
                         "cannot be judged again for the map"}
    else:
        cond = stored_inputs.get("retest_conditions")
        conditions = None if cond is None else RetestConditions(**cond)
        progress("judging the stored tests again for the element map (an inspection without "
                 "a report does not compute it)")
        again = verdict_record(inputs.serial, judge(
            case, float(stored_inputs.get("false_alarm", 0.01)), conditions,
            calibration=calibration).verdict)
        if same_judgement(v["status"], v.get("statistic"), again["status"],
                          again.get("statistic")):
            return replace(inputs, verdict={**v, "details": {
                **details, "msso": again["details"]["msso"]}, "map_judged_again": True})
        else:
            emap = {"error": f"judged again by batlab {code_version()}, the stored tests give "
                             f"{again['status']} (F {_f(again)}), not the stored "
                             f"{v['status']} (F {_f(v)}): no map is drawn for a verdict it "
                             "does not belong to"}
    return replace(inputs, verdict={**v, "details": {**details, "msso": emap}})


def _f(record: dict) -> str:
    """Return the record's statistic in a few digits ("none" without one)."""
    f = record.get("statistic")
    return "none" if f is None else f"{float(f):.4g}"


def history_table(conn: sa.Connection, serial: str | None = None):
    """Tabulate every inspection (of one bat), one row each, lab units: `batlab export`.

    Parameters
    ----------
    conn : sa.Connection
        The registry.
    serial : str or None
        One bat's serial, or None for all bats.

    Returns
    -------
    pandas.DataFrame
        One row per inspection, the columns ``EXPORT_COLUMNS``.
    """
    import pandas as pd

    from batlab.formatting import decision_level, p_value

    species = {b.serial: b.species for b in reg.list_bats(conn)}
    rows = []
    for i in reg.all_inspections(conn, serial):
        v = i.verdict
        region = v.get("region_in") or [None, None]
        rows.append({
            "serial": i.serial, "species": species.get(i.serial, ""), "inspection": i.id,
            "inspected_at": i.inspected_at, "status": i.status, "altered": i.altered,
            "region_start_in": region[0], "region_end_in": region[1],
            "core_diameter_in": v.get("core_diameter_in"),
            "fill_density_ratio": v.get("fill_density_ratio"),
            "p_value": p_value(v), "false_alarm_rate": decision_level(v),
            **_chance_columns(v),
            "reasons": "; ".join(v.get("reasons") or []),
            "retest_file": i.retest_name, "retest_sha256": i.retest_sha256,
            "baseline_sha256": i.baseline_sha256, "registration_record": i.reference_seq,
            "verdict_record": i.record_seq, "verdict_record_sha256": i.record_sha256,
            "report_path": i.report_path,
            "code": v.get("code") or (i.inputs or {}).get("batlab_version")})
    return pd.DataFrame(rows, columns=EXPORT_COLUMNS)


def _chance_columns(v: dict) -> dict:
    """Return the export's chance columns of a stored verdict (``chance``, ``false_alarm_rate``)."""
    from batlab.formatting import stated_chance

    ch = stated_chance(v) or {}
    cal = ch.get("calibration") or {}
    fa = v.get("false_alarm_rate") if isinstance(v.get("false_alarm_rate"), dict) else {}
    return {"chance": ch.get("value"), "chance_source": ch.get("source"),
            "calibration_record": cal.get("record_seq"),
            "false_alarm_measured": fa.get("measured"), "false_alarm_upper95": fa.get("upper95")}
