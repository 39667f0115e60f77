"""The chance as measured: a verdict's statistic against its bat model's stored clean null.

A *bat model* is what one calibration carries to (docs/scale.md): meta.json's ``model`` when
the lab names it, else the profile itself (``model_name``: the species, the length and a hash
of the profile's stations). ``fleet calibrate --store`` keeps a model's clean re-tests'
statistic F and status (``batlab.registry.calibrations``); ``statement`` turns an inspection's
verdict and the latest calibration of its model into the two things a verdict states:

- ``chance``: how often an unaltered bat differs this much. With a calibration, ``value`` is
  ``updating.tails.measured_chance`` ((1 + b) / (n + 1), b of the n stored clean re-tests at
  least this F) and ``source`` "calibration"; without one, ``value`` is the F distribution's
  p-value and ``source`` "nominal", said as unmeasured wherever it is shown. ``nominal`` is
  that p-value either way.
- ``false_alarm_rate``: the calibration's measured rate (k of n called altered) and its 95 %
  Clopper-Pearson bound, when it was run at the inspection's decision level; else unmeasured.

The decision (``status``) is the method's (``updating.inspect``), on the same calibration:
``calibration_for`` finds it before the inspection, whose decision reads the chance measured
on its clean re-tests' F (``decision.decided_chance``; ``chance.decided_on`` "calibration")
when there are enough of them to show a chance below the decision's level (1,000 or more at
0.1 %), else the nominal (``decided_on`` "nominal"). The calibration's false-alarm count
was made by the nominal decision; it bounds the measured one only where the measured chance
calls fewer bats beyond drift (``rows_bound_decision``), and the rate is said unmeasured
where it does not. Light: numpy; ``updating.tails`` when a calibration is used.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import replace

import numpy as np

from updating.model.units import IN_TO_M

__all__ = ["calibration_for", "model_name", "statement", "stated"]

STATISTIC = "F"
"""The statistic a calibration stores and the chance ranks by (the verdict's ``statistic``)."""


def model_name(profile, species: str, meta: dict | None = None) -> str:
    """Name a bat's model: meta.json's ``model``, else one derived from its profile.

    The derived name is ``SPECIES-LENGTHin-HASH``: the species (lower case, spaces as
    hyphens), the length to 0.1 in and the first 10 hex digits of the SHA-256 of the
    canonical JSON of the species and the profile's stations in inches to 1e-4 in. Two
    profile.csv files with the same stations and species name the same model; any other
    profile (another bat of the same model measured again by caliper included) names
    another, so a lab that wants one calibration to carry across bats of a model says so in
    meta.json (``"model": "..."``) and in ``fleet calibrate --model``.

    Parameters
    ----------
    profile : Profile
        The bat's profile (SI).
    species : str
        meta.json's species.
    meta : dict or None
        meta.json's content (its ``model`` key, when present, is the name).

    Returns
    -------
    str
        The model's name.
    """
    named = (meta or {}).get("model")
    if isinstance(named, str) and named.strip():
        return named.strip()
    x_in = [round(float(x) / IN_TO_M, 4) for x in profile.x_m]
    d_in = [round(float(d) / IN_TO_M, 4) for d in profile.diameter_m]
    text = json.dumps({"species": species.strip().lower(), "x_in": x_in, "diameter_in": d_in},
                      sort_keys=True, separators=(",", ":"))
    slug = re.sub(r"[^a-z0-9]+", "-", species.strip().lower()).strip("-") or "wood"
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()[:10]
    return f"{slug}-{x_in[-1]:.1f}in-{digest}"


def nominal_p(verdict) -> float | None:
    """Return a verdict's p-value from the F distribution (None when no test was made)."""
    fit = None if verdict.details is None else verdict.details.fit
    p = None if fit is None else fit.p_value
    if p is None or not math.isfinite(float(p)):
        conf = verdict.confidence
        p = None if conf is None or not math.isfinite(float(conf)) else 1.0 - float(conf)
    return None if p is None else min(max(float(p), 0.0), 1.0)


def null_statistics(calibration) -> np.ndarray:
    """Return a stored calibration's clean statistics (NaN where a re-test had none)."""
    values = calibration.null.get(calibration.statistic) or []
    return np.array([np.nan if v is None else float(v) for v in values], dtype=float)


def rows_bound_decision(null: np.ndarray, level: float, dof) -> bool:
    """Tell whether a calibration's false-alarm count bounds the measured decision's.

    Its re-tests were judged on the nominal chance. The decision's outcome "altered" needs
    the change significant, and only that reads the chance, so the nominal decision's alarms
    include the measured one's wherever the measured chance calls no F significant that the
    nominal leaves below it: where the F past which the stored re-tests measure a chance
    below the level (``updating.tails.measured_cut``) is at least the F distribution's
    critical value at this inspection's degrees of freedom (``updating.tails.f_isf``).

    Parameters
    ----------
    null : numpy.ndarray
        The clean re-tests' F of the calibration the decision read (``null_statistics``).
    level : float
        The decision's false-alarm rate.
    dof : sequence of int or None
        The inspection's (q, N - p_1); None: not known (False).

    Returns
    -------
    bool
    """
    from updating.inspect.decision import CLEAR_LEVEL
    from updating.tails import f_isf, measured_cut

    if not dof or min(int(d) for d in dof) < 1:
        return False
    alpha = min(CLEAR_LEVEL, level)
    return measured_cut(null, alpha) >= f_isf(alpha, int(dof[0]), int(dof[1]))


def unusable(calibration, model: str | None) -> str | None:
    """Return why a calibration cannot state this release's chance (None: it can).

    It must have measured the same statistic (``STATISTIC``) at the same version
    (``STATISTIC_VERSION``); a calibration stored before versions were kept measured an
    unknown one.
    """
    from updating.inspect.nested import STATISTIC_VERSION  # heavy: only with a calibration

    if calibration.statistic != STATISTIC:
        return (f"the calibration of bat model {model} measured {calibration.statistic}, "
                f"not {STATISTIC}")
    version = calibration.statistic_version
    if version != STATISTIC_VERSION:
        said = (f"version {version}" if version is not None
                else "an unknown version (stored before versions were kept)")
        return (f"the stored calibration measured {STATISTIC} {said}, this release computes "
                f"version {STATISTIC_VERSION}: re-run fleet calibrate")
    return None


def _calibration_dict(calibration, exceeding: int | None) -> dict:
    origin = calibration.origin or {}
    return {"model": calibration.model, "n": calibration.n, "exceeding": exceeding,
            "false_alarms": calibration.false_alarms,
            "false_alarm_upper95": calibration.false_alarm_upper95,
            "record_seq": calibration.record_seq, "statistic": calibration.statistic,
            "statistic_version": calibration.statistic_version, "code": calibration.code,
            "signer": origin.get("signer"), "shipped": bool(origin.get("shipped"))}


def statement(verdict, model: str | None, calibration=None,
              unmeasured_why: str | None = None) -> dict:
    """State a verdict's chance and false-alarm rate (module docstring).

    Parameters
    ----------
    verdict : updating.inspect.verdict.Verdict
        The inspection's verdict (its ``statistic``, p-value and decision level).
    model : str or None
        The bat's model (None: not known, no calibration looked up).
    calibration : StoredCalibration or None
        The latest stored calibration of the model.
    unmeasured_why : str or None
        Why there is no calibration, in words (default: none stored for the model).

    Returns
    -------
    dict
        ``{"chance": {...}, "false_alarm_rate": {...}}`` in JSON types; ``chance.decided_on``
        says which chance the decision read (module docstring).
    """
    nominal = nominal_p(verdict)
    fit = None if verdict.details is None else verdict.details.fit
    decision = "nominal" if fit is None else fit.decided_on
    level = float(verdict.false_alarm_rate)
    stat = float(verdict.statistic) if verdict.statistic is not None else math.nan
    if calibration is not None:
        why_not = unusable(calibration, model)
        if why_not:
            unmeasured_why, calibration = why_not, None
    if calibration is None:
        why = unmeasured_why or (f"no calibration of bat model {model} is stored"
                                 if model else "no calibration was looked up")
        chance = {"value": nominal, "source": "nominal", "calibration": None,
                  "nominal": nominal, "model": model, "unmeasured": why,
                  "decided_on": decision}
        return {"chance": chance, "false_alarm_rate": {
            "source": "unmeasured", "false_alarms": None, "n": None, "measured": None,
            "upper95": None, "level": level, "model": model, "unmeasured": why,
            "decided_on": decision}}
    from updating.tails import measured_chance, pareto_tail

    null = null_statistics(calibration)
    value = exceeding = tail = None
    if math.isfinite(stat) and nominal is not None:
        measured = measured_chance(stat, null)
        value, exceeding = measured.value, measured.exceeding
        if exceeding == 0:
            tail = pareto_tail(stat, null)
    chance = {"value": value, "source": "calibration",
              "calibration": _calibration_dict(calibration, exceeding), "nominal": nominal,
              "model": model, "beyond_measured": exceeding == 0 if exceeding is not None
              else None, "extrapolated": tail, "decided_on": decision}
    run_level = calibration.summary.get("false_alarm")
    if decision == "calibration" and not rows_bound_decision(
            null, level, None if fit is None else fit.dof):
        rate = {"source": "unmeasured", "false_alarms": None, "n": None, "measured": None,
                "upper95": None, "level": level, "model": model,
                "unmeasured": f"the calibration of bat model {model} judged its re-tests on "
                              "the F distribution's chance, and the measured chance this "
                              "verdict was decided on calls more of them beyond drift"}
    elif run_level is not None and math.isclose(float(run_level), level):
        k, n = calibration.false_alarms, calibration.n
        rate = {"source": "calibration", "false_alarms": k, "n": n, "measured": k / n,
                "upper95": calibration.false_alarm_upper95, "level": level, "model": model}
    else:
        rate = {"source": "unmeasured", "false_alarms": None, "n": None, "measured": None,
                "upper95": None, "level": level, "model": model,
                "unmeasured": f"the calibration of bat model {model} was run at a decision "
                              f"level of {run_level}, this inspection's is {level:g}"}
    return {"chance": chance, "false_alarm_rate": {**rate, "decided_on": decision}}


def calibration_for(conn, model: str | None, unmeasured_why: str | None = None):
    """Return (the calibration an inspection of a ``model`` bat reads, why there is none).

    The registry's latest of the model, unless a key record there revoked or retired the
    key that signed an imported one; else the one batlab ships
    (``registry.calibration_files.shipped_calibration``), if any. Looked up before the
    inspection: its decision reads the chance measured on it (``null_statistics``) and
    ``stated`` states it.

    Parameters
    ----------
    conn : sa.Connection or None
        The registry; None: the shipped calibration only.
    model : str or None
        The bat's model (None: none looked up).
    unmeasured_why : str or None
        Why no registry was read, in words.

    Returns
    -------
    calibration : StoredCalibration or None
    why : str or None
        Why there is none, in words.
    """
    if not model:
        return None, unmeasured_why
    calibration, why = _calibration_of(conn, model)
    return calibration, why or unmeasured_why


def stated(result, calibration, unmeasured_why: str | None = None):
    """Return an inspection's result with its chance stated from ``calibration`` (``statement``)."""
    return replace(result, stated=statement(result.verdict, result.model, calibration,
                                            unmeasured_why))


def _calibration_of(conn, model: str):
    """Return (the calibration to use, why none is) for bat model ``model``.

    The registry's latest, else batlab's shipped one; the first of them that is usable
    (``unusable``, and not signed by a key the registry's key records ended).
    """
    from batlab.registry import ended_keys, latest_calibration, shipped_calibration

    why = None
    if conn is not None:
        calibration = latest_calibration(conn, model)
        signer = (calibration.origin or {}).get("signer") if calibration else None
        ended = ended_keys(conn) if signer else {}
        if signer in ended:
            why = (f"the calibration of bat model {model} was signed by key {signer}, "
                   f"{ended[signer]}")
        elif calibration is not None:
            why = unusable(calibration, model)
            if why is None:
                return calibration, None
    try:
        shipped = shipped_calibration(model)
    except ValueError as exc:  # a changed file, or one signed by an unlisted key
        return None, why or f"batlab's shipped calibration was refused: {exc}"
    if shipped is not None and unusable(shipped, model) is None:
        return shipped, None
    return None, why or (None if shipped is None else unusable(shipped, model))
