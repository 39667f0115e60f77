"""The re-test's own conditions (``retest.json``).

The re-test's own conditions (``retest.json``, ../docs/inspection.md), every key optional:

    {"weight_lb": 2.2388, "accelerometer_mass_g": 4.1, "temperature_c": 24.0,
     "tested_on": "2026-05-02"}

Read into SI (``RetestConditions``); a bad file or key is a one-line ``ValueError`` naming
the file and the key.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from pathlib import Path

from ema.io.finite import finite_number
from updating.model.json_input import read_json_object
from updating.model.units import LB_TO_KG

RANGES = {  # key: (lowest, highest) accepted, in the file's units
    "weight_lb": (0.5, 5.0),
    "accelerometer_mass_g": (0.0, 100.0),
    "temperature_c": (-20.0, 60.0),
}


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


def _number(path: Path, raw: dict, key: str) -> float | None:
    value = raw.get(key)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{path}: {key} must be a number, not {value!r}")
    return finite_number(value, f"{path}: {key}", *RANGES[key])


def read_retest_meta(path: str | Path) -> RetestConditions:
    """Read retest.json; ValueError (one line, naming the file and key) when unusable."""
    path = Path(path)
    return conditions_from_dict(read_json_object(path), path)


def conditions_from_dict(raw: dict, source: str | Path) -> RetestConditions:
    """Read a test's conditions from a dict.

    A test's conditions from a dict with retest.json's keys (also meta.json's optional
    ``weight_lb``, ``accelerometer_mass_g``, ``temperature_c`` of the baseline); ``source``
    names it in errors.
    """
    path = source
    weight = _number(path, raw, "weight_lb")
    mass_g = _number(path, raw, "accelerometer_mass_g")
    temp = _number(path, raw, "temperature_c")
    day = raw.get("tested_on")
    if day is not None:
        try:
            day = dt.date.fromisoformat(str(day)).isoformat()
        except ValueError:
            raise ValueError(f"{path}: tested_on must be a date YYYY-MM-DD, not {day!r}") \
                from None
    return RetestConditions(None if weight is None else weight * LB_TO_KG,
                            None if mass_g is None else mass_g * 1e-3, temp, day)
