"""What an inspection hands on: the fitted tests, the report's inputs, the contract's JSON.

A light module (numpy and the unit constants): ``batlab.report`` draws a page from these
types without loading the stages. Positions are SI inside; the contract dict
(docs/contract.md) is in inches from the knob end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from updating.model.units import IN_TO_M

__all__ = [
    "FittedTest", "ReportInputs", "contract_dict", "jsonable", "result_dict",
    "stored_contract_dict", "verdict_record",
]


if TYPE_CHECKING:
    from ema.io.frf_data import FrfTest
    from updating.correlate.measured import MeasuredModes
    from updating.inspect.verdict import Verdict
    from updating.model.profile import Profile
    from updating.model.reference import BatReference


FORCED_KEY = "registered_with_force"
"""The stored meta's key that holds why a baseline registered with ``--force`` looked odd."""


@dataclass(frozen=True)
class FittedTest:
    """One test file, read and fitted.

    Attributes
    ----------
    name : str
        The file's name (for messages and the report).
    test : FrfTest
        The FRFs.
    fit : ModalFit or None
        The modal fit (``ema.modal_fit.ModalFit``), or None for a registered baseline whose
        modes come from the registry.
    modes : MeasuredModes
        Elastic modes at the impact points, in the baseline's point order.
    """

    name: str
    test: FrfTest
    fit: object | None
    modes: MeasuredModes


@dataclass(frozen=True)
class ReportInputs:
    """What a report is drawn from.

    The verdict as stored (``verdict``: the contract JSON with the verdict's evidence), the
    model and both fitted tests, the bat's meta.json and the provenance (file hashes,
    custody record hashes, inspection number and time). Stored inspections rebuild it from
    the registry alone (``batlab.pipeline.stored.stored_report_inputs``).
    """

    serial: str
    profile: Profile
    reference: BatReference
    baseline: FittedTest
    retest: FittedTest
    verdict: dict
    meta: dict
    provenance: dict
    conditions: dict | None = None
    """The re-test's conditions from retest.json, SI (``RetestConditions`` as a dict), or
    None when none were given."""


def _in(x_m: float) -> float:
    return round(float(x_m) / IN_TO_M, 4)


def _num(v) -> float | None:
    return None if v is None or not math.isfinite(float(v)) else float(v)


def same_judgement(status: str, statistic: float | None, again_status: str,
                   again_statistic: float | None, rtol: float = 1e-6) -> bool:
    """Say whether a re-test judged again gives the same verdict: its status and its F.

    F within ``rtol`` (relative); no F (a refusal) or NaN (inconclusive before the test) on
    both sides counts as the same. A resumed calibration (``fleet.calibrate.same_row``) and
    a report's element map judged again (``stored.with_element_map``) both ask it.
    """
    if status != again_status:
        return False
    if statistic is None or again_statistic is None:
        return statistic is None and again_statistic is None
    return bool(np.isclose(statistic, again_statistic, rtol=rtol, atol=0.0, equal_nan=True))


def lab_units(values: dict) -> dict:
    """SI readings in the contract's units: *_m -> *_in, *_kg -> *_g, *_rel -> *_pct."""
    out = {}
    for key, v in values.items():
        if key.endswith("_m"):
            out[key[:-2] + "_in"] = round(float(v) / IN_TO_M, 4)
        elif key.endswith("_kg"):
            out[key[:-3] + "_g"] = round(1e3 * float(v), 2)
        elif key.endswith("_rel"):
            out[key[:-4] + "_pct"] = round(100 * float(v), 2)
        else:
            out[key] = _num(v)
    return out


def finding_dict(finding, spread: dict | None = None) -> dict | None:
    """Write a verdict's finding as the contract fixes it (None when nothing was found).

    Parameters
    ----------
    finding : updating.inspect.finding.Finding or None
        What changed, SI.
    spread : dict or None
        The leave-one-out spread of its reading (``updating.inspect.robustness``), SI name
        -> (lowest, highest), when it was checked.

    Returns
    -------
    dict or None
        ``kind``, ``legal``, ``region_in``, ``rule``, ``reading`` and ``uncertainty`` (1
        sigma) in the lab's units (in, g, %), and ``leave_one_out`` (each reading's lowest
        and highest with any one mode or point left out) when given.
    """
    if finding is None:
        return None
    a, b = finding.region_m
    out = {"kind": finding.kind, "legal": bool(finding.legal),
           "region_in": [_in(a), _in(b)], "rule": finding.rule,
           "reading": lab_units(finding.reading),
           "uncertainty": lab_units(finding.uncertainty)}
    if spread:
        lo, hi = (lab_units({k: v[i] for k, v in spread.items()}) for i in (0, 1))
        out["leave_one_out"] = {k: [lo[k], hi[k]] for k in lo}
    return out


def contract_dict(serial: str, verdict: Verdict, stated: dict | None = None) -> dict:
    """Write the verdict as docs/contract.md fixes it.

    Status, altered true/false/null, reasons; inches from the knob end; region, core and
    fill null unless altered; the chance an unaltered bat differs this much (``chance``) and
    the false-alarm rate (``false_alarm_rate``), as measured on the bat model's stored
    calibration or said unmeasured (``batlab.pipeline.chance.statement``); the decision's
    confidence; and the code that judged (``code``, ``batlab.version``). The reasons state
    the chance as ``chance`` does (``batlab.formatting.reasons_with_chance``).

    Parameters
    ----------
    serial : str
        The bat's serial number.
    verdict : Verdict
        The inspection's verdict.
    stated : dict or None
        ``statement``'s chance and false-alarm rate; None: nominal, no calibration looked up.

    Returns
    -------
    dict
        The contract's JSON object.
    """
    from batlab.formatting import reasons_with_chance
    from batlab.pipeline.chance import nominal_p, statement
    from batlab.version import code_version

    if stated is None:
        stated = statement(verdict, None)
    altered = verdict.altered is True
    region = verdict.region_m if altered else None
    core = verdict.core_diameter_m if altered else None
    fill = verdict.fill_density_ratio if altered else None
    elements = [
        {"x0_in": _in(a), "x1_in": _in(b), "alpha": float(al), "beta": float(be)}
        for a, b, al, be in zip(verdict.element_x0_m, verdict.element_x1_m, verdict.alpha,
                                verdict.beta, strict=True)
    ]
    chance = jsonable(stated["chance"])
    return {
        "serial": serial,
        "status": verdict.status.value,
        "altered": verdict.altered if verdict.altered is None else bool(verdict.altered),
        "reasons": reasons_with_chance([str(r) for r in verdict.reasons], nominal_p(verdict),
                                       chance),
        "region_in": None if region is None else [_in(region[0]), _in(region[1])],
        "core_diameter_in": None if core is None else round(float(core) / IN_TO_M, 4),
        "fill_density_ratio": _num(fill),
        "finding": finding_dict(verdict.finding, _spread(verdict)),
        "elements": elements,
        "chance": chance,
        "confidence": _num(verdict.confidence),
        "false_alarm_rate": jsonable(stated["false_alarm_rate"]),
        "code": code_version(),
    }


def result_dict(result) -> dict:
    """Return an inspection result's contract dict, its chance as stated (``contract_dict``)."""
    return contract_dict(result.serial, result.verdict, result.stated)


def _spread(verdict: Verdict) -> dict | None:
    """Return the leave-one-out spread of an altered verdict's finding, SI, or None."""
    fit = None if verdict.details is None else verdict.details.fit
    if verdict.altered is not True or fit is None or not fit.leave_one_out:
        return None
    return fit.leave_one_out.get("spread") or None


def jsonable(value):
    """Convert numpy scalars and arrays, tuples and containers to JSON types.

    Parameters
    ----------
    value : object
        Dicts, lists, tuples, numpy arrays and scalars, Python scalars, None or strings
        (anything else becomes its ``str``).

    Returns
    -------
    object
        The same structure in JSON types, NaN and infinities as None.
    """
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return _num(value)
    if value is None or isinstance(value, str):
        return value
    return str(value)


RECORD_ONLY_KEYS = ("statistic", "moisture", "uncertainty", "modes", "details")
"""What ``verdict_record`` adds to the contract dict."""


def stored_contract_dict(record: dict, inputs: dict | None = None) -> dict:
    """Return the contract dict of a stored verdict record (``verdict_record``'s inverse part).

    A record stored before verdicts named their code and chance gets ``code`` from its
    inputs' ``batlab_version`` and a nominal ``chance`` (said unmeasured) from its p-value.

    Parameters
    ----------
    record : dict
        A stored inspection's verdict.
    inputs : dict or None
        The inspection's stored inputs.

    Returns
    -------
    dict
        The contract's JSON object, as ``contract_dict`` wrote it.
    """
    out = {k: v for k, v in record.items() if k not in RECORD_ONLY_KEYS}
    if "code" not in out:
        out["code"] = (inputs or {}).get("batlab_version")
    if "chance" not in out:
        from batlab.formatting import p_value

        p = None if out.get("status") == "inconclusive" else p_value(record)
        out["chance"] = {"value": p, "source": "nominal", "calibration": None, "nominal": p,
                         "model": None, "unmeasured": "judged before batlab measured chances"}
    return out


def verdict_record(serial: str, verdict: Verdict, stated: dict | None = None) -> dict:
    """Write what the registry keeps of an inspection.

    Parameters
    ----------
    serial : str
        The bat's serial number.
    verdict : Verdict
        The inspection's verdict.
    stated : dict or None
        Its chance and false-alarm rate (``contract_dict``).

    Returns
    -------
    dict
        The contract dict and the verdict's statistic, drift, uncertainties, paired modes
        and details (with ``plane_split``, the bending pairs' splits' reading), in JSON
        types.
    """
    out = contract_dict(serial, verdict, stated)
    details = {} if verdict.details is None else verdict.details.to_json_dict()
    if verdict.plane_split is not None:
        details["plane_split"] = verdict.plane_split.to_json_dict()
    out.update(jsonable({"statistic": verdict.statistic, "moisture": verdict.moisture,
                         "uncertainty": verdict.uncertainty,
                         "modes": [m.to_json_dict() for m in verdict.modes],
                         "details": details}))
    return out
