"""The re-test's own conditions (``retest.json``).

The re-test's own conditions (``retest.json``, ../docs/inspection.md), every key optional:

    {"weight_lb": 2.2388, "accelerometer_mass_g": 4.1, "temperature_c": 24.0,
     "tested_on": "2026-05-02"}

Read into SI (``RetestConditions``); what each key must hold is
``updating.model.lab_input.CONDITION_KEYS`` (a date from 1990 to tomorrow, numbers as JSON
numbers within their ranges); a bad file or key is a one-line ``ValueError`` naming the file
and the key.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from updating.model.json_input import read_json_object, read_keys
from updating.model.lab_input import CONDITION_KEYS
from updating.model.units import LB_TO_KG


@dataclass(frozen=True)
class RetestConditions:
    """What the lab knows about the re-test (None: not given).

    Attributes
    ----------
    weight_kg
        The bat on a scale at the re-test (no accelerometer on it).
    sensor_mass_kg
        The accelerometer (and cable) mass used at the re-test.
    temperature_c
        The lab's temperature at the re-test.
    tested_on
        The date of the re-test (ISO string).
    """

    weight_kg: float | None = None
    sensor_mass_kg: float | None = None
    temperature_c: float | None = None
    tested_on: str | None = None


def read_retest_meta(path: str | Path) -> RetestConditions:
    """Read retest.json; ValueError (one line, naming the file and key) when unusable."""
    path = Path(path)
    return conditions_from_dict(read_json_object(path), path)


def conditions_from_dict(raw: dict, source: str | Path) -> RetestConditions:
    """Read a test's conditions from a dict.

    A test's conditions from a dict with retest.json's keys (``CONDITION_KEYS``; also
    meta.json's optional ``weight_lb``, ``accelerometer_mass_g``, ``temperature_c``,
    ``tested_on`` of the baseline); ``source`` names it in errors.
    """
    v = read_keys(raw, CONDITION_KEYS, source)
    weight, mass_g = v.get("weight_lb"), v.get("accelerometer_mass_g")
    return RetestConditions(None if weight is None else weight * LB_TO_KG,
                            None if mass_g is None else mass_g * 1e-3, v.get("temperature_c"),
                            v.get("tested_on"))
