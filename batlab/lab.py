"""The lab profile: who tested the bat, where, and with what (the report's certificate).

One JSON object kept in ``$BATLAB_LAB``, else ``$XDG_CONFIG_HOME/batlab/lab.json``
(``batlab.signing.config_dir``), written by ``batlab lab --name ... --operator ...``. Its
fields (``LAB_FIELDS``) are the lab and its equipment: name, address, operator, the impact
hammer and its sensitivity (mV/N), the accelerometer and its sensitivity (mV/(m/s^2)), the
analysis band (Hz), frequency resolution (Hz) and the number of averages. A report without a
profile says so in its certificate block rather than leaving the fields out.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from ema.io.atomic_write import atomic_write

LAB_FIELDS = {
    "name": "Laboratory",
    "address": "Address",
    "operator": "Operator",
    "hammer": "Impact hammer",
    "hammer_sensitivity_mv_per_n": "Hammer sensitivity (mV/N)",
    "accelerometer": "Accelerometer",
    "accelerometer_sensitivity_mv_per_ms2": "Accelerometer sensitivity (mV/(m/s²))",
    "band_hz": "Analysis band (Hz)",
    "resolution_hz": "Frequency resolution (Hz)",
    "averages": "Averages per point",
}
"""The profile's keys and the certificate's label for each."""
NUMBER_FIELDS = ("hammer_sensitivity_mv_per_n", "accelerometer_sensitivity_mv_per_ms2",
                 "resolution_hz", "averages")


def lab_path(env: dict | None = None) -> Path:
    """Return where the lab profile is kept: ``$BATLAB_LAB``, else the config folder's."""
    from batlab.signing import config_dir

    env = os.environ if env is None else env
    if env.get("BATLAB_LAB"):
        return Path(env["BATLAB_LAB"]).expanduser()
    return config_dir(env) / "lab.json"


def check_lab(raw: object, where: str | Path) -> dict:
    """Return a lab profile read from JSON; ValueError naming ``where`` and the bad key."""
    if not isinstance(raw, dict):
        raise ValueError(f"{where}: not a JSON object")
    unknown = sorted(set(raw) - set(LAB_FIELDS))
    if unknown:
        raise ValueError(f"{where}: unknown key {unknown[0]!r} (known: {', '.join(LAB_FIELDS)})")
    for key in NUMBER_FIELDS:
        if key in raw and (not isinstance(raw[key], (int, float)) or isinstance(raw[key], bool)
                           or raw[key] <= 0):
            raise ValueError(f"{where}: {key} must be a positive number, not {raw[key]!r}")
    band = raw.get("band_hz")
    if band is not None and not (isinstance(band, list) and len(band) == 2
                                 and all(isinstance(b, (int, float)) for b in band)
                                 and 0 <= band[0] < band[1]):
        raise ValueError(f"{where}: band_hz must be [low, high] in Hz, not {band!r}")
    return dict(raw)


def read_lab(env: dict | None = None) -> dict | None:
    """Return the lab profile (``check_lab``), or None when there is none."""
    path = lab_path(env)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the lab profile ({exc.strerror})") from None
    try:
        raw = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not valid JSON ({exc.msg}, line {exc.lineno})") from None
    return check_lab(raw, path)


def write_lab(fields: dict, env: dict | None = None) -> Path:
    """Merge ``fields`` into the lab profile and write it atomically; return its path."""
    path = lab_path(env)
    merged = check_lab({**(read_lab(env) or {}), **fields}, path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, lambda tmp: tmp.write_text(json.dumps(merged, indent=2) + "\n",
                                                  encoding="utf-8"))
    return path


def lab_rows(lab: dict | None) -> list[tuple[str, str]]:
    """Return the certificate's (label, text) rows for the lab, in ``LAB_FIELDS`` order."""
    if not lab:
        return [("Laboratory", "no lab profile (set one with: batlab lab --name ...)")]
    rows = []
    for key, label in LAB_FIELDS.items():
        val = lab.get(key)
        if val is None:
            continue
        if key == "band_hz":
            val = f"{val[0]:g}–{val[1]:g}"
        elif isinstance(val, float):
            val = f"{val:g}"
        rows.append((label, str(val)))
    return rows
