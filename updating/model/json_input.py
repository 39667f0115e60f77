"""Lab files in JSON: read into a dict, and their keys checked, with one wording throughout.

Every lab JSON file (meta.json, retest.json, a bar description, an acquisition sidecar or
channel description) is read by ``read_json_object``; its errors are one line naming the
file: "PATH: no such file", "PATH: is a directory, not a file", "PATH: empty file",
"PATH: not a text file",
"PATH: not valid JSON (MSG, line N)", "PATH: expected a JSON object". A UTF-8 byte-order
mark and Windows line ends are accepted.

A file's keys are described by a table of ``Key`` (meta.json's: ``lab_input.META_KEYS``,
retest.json's: ``lab_input.CONDITION_KEYS``) and checked by ``read_keys``: each error is one
line naming the file, the key and what was expected, e.g.
``meta.json: key 'weight_lb' must be a number (lb), not the text '1.9259'``. JSON's types
are kept: a number written as text, a date written as a number, ``true`` for a number are
refused (a spreadsheet's export that quotes everything is a slip to fix, not to guess at).
Keys a table does not name are the caller's to mention (``unused_keys``) and are otherwise
ignored, as the contract says.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

EARLIEST_DATE = dt.date(1990, 1, 1)
"""No lab test is older than this (batlab's tests are of bats in use)."""


def read_json_object(path: str | Path) -> dict:
    """Read a JSON file whose top level is an object.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    dict
        The file's object.

    Raises
    ------
    ValueError
        One line naming the file when it is missing, unreadable, not JSON or not an object.
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path}: is a directory, not a file")
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    try:
        text = path.read_text(encoding="utf-8-sig")
        if not text.strip():
            raise ValueError(f"{path}: empty file")
        raw = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not valid JSON ({exc.msg}, line {exc.lineno})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file") from None
    except OSError as exc:
        raise ValueError(f"{path}: cannot read ({exc.strerror})") from None
    if not isinstance(raw, dict):
        raise ValueError(f"{path}: expected a JSON object")
    return raw


@dataclass(frozen=True)
class Key:
    """What one key of a lab JSON file must hold.

    Attributes
    ----------
    kind : str
        ``"number"``, ``"numbers"`` (a non-empty list of numbers), ``"text"`` (non-blank),
        ``"date"`` (text ``YYYY-MM-DD`` from ``EARLIEST_DATE`` to tomorrow) or
        ``"records"`` (a non-empty list of objects, each holding every key of ``fields``:
        a moisture meter's readings, ``[{"x_in": 31.0, "mc_pct": 8.9}, ...]``).
    unit : str
        The value's unit, for messages (``"lb"``).
    lo, hi : float
        Accepted range of a number (each of a list), in the file's units.
    required : bool
        The key must be present and not null.
    rule : callable or None
        For text: returns why a value is unusable (``lab_input.serial_problem``), or None.
    fields : dict of str to Key or None
        For records: what each object's keys must hold (every one required).
    """

    kind: str
    unit: str = ""
    lo: float = -math.inf
    hi: float = math.inf
    required: bool = False
    rule: Callable[[str], str | None] | None = None
    fields: dict[str, Key] | None = None

    @property
    def expected(self) -> str:
        """What the key holds, as messages say it."""
        unit = f" ({self.unit})" if self.unit else ""
        if self.kind == "records":
            return "a list of objects {" + ", ".join(self.fields or {}) + "}"
        return {"number": f"a number{unit}", "numbers": f"a list of numbers{unit}",
                "text": "text", "date": "a date as text YYYY-MM-DD"}[self.kind]


def shown(value) -> str:
    """Return a JSON value as a message shows it: its type, and at most 40 characters of it."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        text = repr(value[:40]) + ("..." if len(value) > 40 else "")
        return f"the text {text}"
    if isinstance(value, float) and not math.isfinite(value):
        return {math.inf: "Infinity", -math.inf: "-Infinity"}.get(value, "NaN")
    if isinstance(value, numbers.Number):
        return f"the number {value!r}"
    kind = "list" if isinstance(value, list) else "object"
    text = json.dumps(value)
    return f"the {kind} {text[:40]}" + ("..." if len(text) > 40 else "")


def _is_number(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _number(value, name: str, key: Key) -> float:
    """One number of ``key`` (named ``name`` in messages): finite and within range."""
    unit = f" {key.unit}" if key.unit else ""
    if not _is_number(value):
        raise ValueError(f"{name} must be a number{f' ({key.unit})' if unit else ''}, "
                         f"not {shown(value)}")
    try:
        number = float(value)
    except OverflowError:  # an integer beyond any float
        number = math.inf
    if not math.isfinite(number):
        raise ValueError(f"{name} must be a finite number, not {shown(number)}")
    if not key.lo <= number <= key.hi:
        to = " to " if key.lo < 0 else "-"
        raise ValueError(f"{name} = {number:g} is outside {key.lo:g}{to}{key.hi:g}{unit}")
    return number


def _date(value, name: str, key: Key, today: dt.date) -> str:
    if not isinstance(value, str):
        raise ValueError(f"{name} must be {key.expected}, not {shown(value)}")
    try:
        day = dt.date.fromisoformat(value.strip()) if len(value.strip()) == 10 else None
    except ValueError:
        day = None
    if day is None:
        raise ValueError(f"{name} must be {key.expected}, not {shown(value)}")
    latest = today + dt.timedelta(days=1)
    if not EARLIEST_DATE <= day <= latest:
        raise ValueError(f"{name} = {day.isoformat()} is outside {EARLIEST_DATE.isoformat()} "
                         f"to {latest.isoformat()} (tomorrow)")
    return day.isoformat()


def _records(value, name: str, key: Key, today: dt.date) -> list[dict]:
    """Check a list of objects, each holding every key of ``key.fields`` (others ignored)."""
    if not isinstance(value, list):
        raise ValueError(f"{name} must be {key.expected}, not {shown(value)}")
    if not value:
        raise ValueError(f"{name} is empty, expected {key.expected}")
    out = []
    for k, item in enumerate(value):
        if not isinstance(item, dict):
            raise ValueError(f"{name}[{k}] must be an object {{{', '.join(key.fields)}}}, "
                             f"not {shown(item)}")
        record = {}
        for field, sub in key.fields.items():
            if item.get(field) is None:
                raise ValueError(f"{name}[{k}] has no {field!r}, expected {sub.expected}")
            record[field] = _value(item[field], f"{name}[{k}][{field!r}]", sub, today)
        out.append(record)
    return out


def _value(value, name: str, key: Key, today: dt.date):
    if key.kind == "number":
        return _number(value, name, key)
    if key.kind == "date":
        return _date(value, name, key, today)
    if key.kind == "numbers":
        if not isinstance(value, list):
            raise ValueError(f"{name} must be {key.expected}, not {shown(value)}")
        if not value:
            raise ValueError(f"{name} is empty, expected {key.expected}")
        return [_number(v, f"{name}[{k}]", key) for k, v in enumerate(value)]
    if key.kind == "records":
        return _records(value, name, key, today)
    if not isinstance(value, str):
        raise ValueError(f"{name} must be {key.expected}, not {shown(value)}")
    problem = key.rule(value) if key.rule else None
    problem = problem or (None if value.strip() else "must not be empty")
    if problem:
        raise ValueError(f"{name} {problem}, not {shown(value)}")
    return value


def read_keys(raw: dict, keys: dict[str, Key], where: str | Path,
              today: dt.date | None = None) -> dict:
    """Check a lab JSON object's keys against their table.

    Parameters
    ----------
    raw : dict
        The file's object (``read_json_object``).
    keys : dict of str to Key
        What each key the program uses must hold.
    where : str or Path
        The file, for messages.
    today : datetime.date or None
        The date a ``"date"`` key may be at most one day after (default: today).

    Returns
    -------
    dict
        Each key of ``keys`` present and not null: its checked value (float, list of
        float, or text; a date as ``YYYY-MM-DD``).

    Raises
    ------
    ValueError
        One line naming ``where``, the key and what was expected.
    """
    today = today or dt.date.today()
    out = {}
    for name, key in keys.items():
        value = raw.get(name)
        if value is None:
            if key.required:
                raise ValueError(f"{where}: key {name!r} is null, expected {key.expected}"
                                 if name in raw else
                                 f"{where}: missing key {name!r}, expected {key.expected}")
            continue
        try:
            out[name] = _value(value, f"key {name!r}", key, today)
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
    return out


def unused_keys(raw: dict, keys: dict[str, Key]) -> list[str]:
    """Return the keys of a lab JSON object that its table does not name, in file order."""
    return [k for k in raw if k not in keys]
