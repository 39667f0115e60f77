"""A test's own conditions (``retest.json``, and the registration's in ``meta.json``).

The re-test's own conditions (``retest.json``, ../docs/contract.md), every key optional:

    {"weight_lb": 2.2388, "accelerometer_mass_g": 4.1, "temperature_c": 24.0,
     "tested_on": "2026-05-02", "humidity_pct": 45, "conditioned_h": 48,
     "moisture": [{"x_in": 31.0, "mc_pct": 8.9}, {"x_in": 17.0, "mc_pct": 9.4}]}

Read into SI (``RetestConditions``); what each key must hold is
``updating.model.lab_input.CONDITION_KEYS`` (a date from 1990 to tomorrow, numbers as JSON
numbers within their ranges, each moisture reading an object with ``x_in`` and ``mc_pct``);
a bad file or key is a one-line ``ValueError`` naming the file and the key. Whether the
readings lie on the bat is ``stations_problem``'s (it needs the profile).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from updating.model.json_input import read_json_object, read_keys
from updating.model.lab_input import CONDITION_KEYS
from updating.model.units import IN_TO_M, LB_TO_KG


@dataclass(frozen=True)
class RetestConditions:
    """What the lab knows about one test (None: not given).

    Attributes
    ----------
    weight_kg
        The bat on a scale at the test (no accelerometer on it).
    sensor_mass_kg
        The accelerometer (and cable) mass used at the test.
    temperature_c
        The lab's temperature at the test.
    tested_on
        The date of the test (ISO string).
    moisture
        A moisture meter's readings: ((x_m from the knob end, moisture content %), ...), in
        the file's order (a station read several times appears several times).
    humidity_pct
        The test room's relative humidity, %.
    conditioned_h
        Hours the bat spent in the test room before the test.
    """

    weight_kg: float | None = None
    sensor_mass_kg: float | None = None
    temperature_c: float | None = None
    tested_on: str | None = None
    moisture: tuple[tuple[float, float], ...] | None = None
    humidity_pct: float | None = None
    conditioned_h: float | None = None


def read_retest_meta(path: str | Path) -> RetestConditions:
    """Read retest.json; ValueError (one line, naming the file and key) when unusable."""
    path = Path(path)
    return conditions_from_dict(read_json_object(path), path)


def conditions_from_dict(raw: dict, source: str | Path) -> RetestConditions:
    """Read a test's conditions from a dict.

    A test's conditions from a dict with retest.json's keys (``CONDITION_KEYS``; also
    meta.json's optional ``accelerometer_mass_g``, ``temperature_c``, ``tested_on``,
    ``moisture``, ``humidity_pct``, ``conditioned_h`` of the baseline); ``source`` names it
    in errors.
    """
    v = read_keys(raw, CONDITION_KEYS, source)
    weight, mass_g, readings = v.get("weight_lb"), v.get("accelerometer_mass_g"), \
        v.get("moisture")
    return RetestConditions(
        None if weight is None else weight * LB_TO_KG,
        None if mass_g is None else mass_g * 1e-3, v.get("temperature_c"), v.get("tested_on"),
        None if readings is None else tuple((r["x_in"] * IN_TO_M, r["mc_pct"])
                                            for r in readings),
        v.get("humidity_pct"), v.get("conditioned_h"))


def stations_problem(cond: RetestConditions | None, length_m: float) -> str | None:
    """Say which moisture reading lies off a bat ``length_m`` long, None when all are on it.

    Returns
    -------
    str or None
        E.g. "key 'moisture'[2]['x_in'] = 35.5 is off the bat (0-33.1 in from the knob
        end)", for the caller to prefix with the file's name.
    """
    for k, (x_m, _) in enumerate(cond.moisture or () if cond else ()):
        if not -1e-9 <= x_m <= length_m + 1e-9:
            return (f"key 'moisture'[{k}]['x_in'] = {x_m / IN_TO_M:g} is off the bat "
                    f"(0-{length_m / IN_TO_M:.1f} in from the knob end)")
    return None
