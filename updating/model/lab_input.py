"""A bat's lab inputs (meta.json) turned into model inputs, and alteration specs.

meta.json (docs/contract.md): ``META_KEYS`` says what each key must hold: serial (a
``serial_problem``-free text), species, nominal_E_psi, nominal_weight_density_lbf_in3,
weight_lb (the bat on a scale: the registration's mass-line check needs it) and points_in
(the impact points) are required; the baseline's own conditions (``CONDITION_KEYS``:
accelerometer_mass_g, used by diagnose as a prior, temperature_c, tested_on, moisture,
humidity_pct, conditioned_h) and model (the bat model's name, which its calibrations are stored
under) are optional; other keys are ignored (``json_input.unused_keys`` lists them).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from updating.model.json_input import Key, read_json_object, read_keys
from updating.model.material import ISOTROPIC_E_OVER_G, Material, material_from_imperial
from updating.model.sections import Core
from updating.model.units import IN_TO_M, LB_TO_KG

SERIAL_MAX_CHARS = 64
"""Longest serial number (a league's are under 20 characters)."""


def serial_problem(serial: str) -> str | None:
    """Say why a text cannot be a bat's serial number, None when it can.

    A serial names the bat in the registry, in reports and in file names
    (``fleet inspect``'s ``SERIAL.uff``): 1 to ``SERIAL_MAX_CHARS`` printable ASCII
    characters, no path separator, no space at either end, not ``.`` or ``..``.

    Parameters
    ----------
    serial : str
        The text.

    Returns
    -------
    str or None
        What it must be ("must be at most 64 characters (this one has 10000)"), or None.
    """
    if not serial.strip():
        return "must not be empty"
    if len(serial) > SERIAL_MAX_CHARS:
        return f"must be at most {SERIAL_MAX_CHARS} characters (this one has {len(serial)})"
    if any(not " " <= c <= "~" for c in serial):
        return "must be printable ASCII (letters, digits, - _ . and the like)"
    if "/" in serial or "\\" in serial or serial in (".", ".."):
        return "must not hold a path separator (/ or \\) or be . or .."
    if serial != serial.strip():
        return "must not begin or end with a space"
    return None


BAT_MAX_IN = 42.0
"""Longest bat (Rule 3.02(a)): a moisture reading further from the knob is off any bat."""
MOISTURE_READING = {"x_in": Key("number", "in from the knob end", 0.0, BAT_MAX_IN),
                    "mc_pct": Key("number", "% of oven-dry mass", 0.0, 40.0)}
"""One moisture meter reading: where (from the knob end) and what it read (0-40 %: oven-dry
to well past fibre saturation, about 30 %)."""
CONDITION_KEYS = {  # retest.json's keys (every one optional); meta.json's at the baseline
    "weight_lb": Key("number", "lb", 0.5, 5.0),
    "accelerometer_mass_g": Key("number", "g", 0.0, 100.0),
    "temperature_c": Key("number", "C", -20.0, 60.0),
    "tested_on": Key("date"),
    "moisture": Key("records", fields=MOISTURE_READING),
    "humidity_pct": Key("number", "% relative humidity", 0.0, 100.0),
    "conditioned_h": Key("number", "hours in the test room", 0.0, 24.0 * 365),
}
"""A test's own conditions (the re-test's retest.json, the baseline's in meta.json): the
scale, the accelerometer, the room's temperature and humidity, the date, the hours the bat
spent in the test room and a moisture meter's readings along the bat."""
META_KEYS = {  # ranges wider than any bat: plausible.check_meta judges a bat's values
    "serial": Key("text", required=True, rule=serial_problem),
    "species": Key("text", required=True),
    "nominal_E_psi": Key("number", "psi", 1e4, 1e8, required=True),
    "nominal_weight_density_lbf_in3": Key("number", "lbf/in^3", 1e-4, 1.0, required=True),
    "weight_lb": Key("number", "lb", 0.05, 50.0, required=True),
    "points_in": Key("numbers", "in from the knob end", -10.0, 100.0, required=True),
    "model": Key("text"),  # the bat model's name (calibrations: batlab.pipeline.chance)
    **{k: v for k, v in CONDITION_KEYS.items() if k != "weight_lb"},
}
"""What each key of meta.json must hold."""


@dataclass(frozen=True)
class BatMeta:
    """A bat's meta.json read into model inputs.

    Attributes
    ----------
    serial, species : str
        The bat's serial and species.
    material : Material
        The species' handbook wood.
    weight_kg : float or None
        The registered weight, kg (None only for a bat registered before it was required).
    points_m : ndarray
        The impact points from the knob end, m.
    extra : dict
        The file's whole content.
    accelerometer_mass_kg : float or None
        The accelerometer's data-sheet mass, kg.
    """

    serial: str
    species: str
    material: Material
    weight_kg: float | None
    points_m: np.ndarray
    extra: dict = field(default_factory=dict)
    accelerometer_mass_kg: float | None = None


def read_meta(path: str | Path, e_over_g: float = ISOTROPIC_E_OVER_G) -> BatMeta:
    """Read meta.json; raise ValueError naming the file, the key and what was expected.

    Parameters
    ----------
    path : str or Path
        meta.json.
    e_over_g : float
        The wood's E/G.

    Returns
    -------
    BatMeta
        The bat's inputs, SI.
    """
    path = Path(path)
    raw = read_json_object(path)
    v = read_keys(raw, META_KEYS, path)
    sensor_g = v.get("accelerometer_mass_g")
    return BatMeta(v["serial"], v["species"],
                   material_from_imperial(v["nominal_E_psi"],
                                          v["nominal_weight_density_lbf_in3"], e_over_g),
                   v["weight_lb"] * LB_TO_KG, np.array(v["points_in"]) * IN_TO_M, raw,
                   None if sensor_g is None else 1e-3 * sensor_g)


FILL_DEFAULTS = {"cork": 1 / 3, "heavy": 1.8, "neutral": 1.0, "core": 1 / 3}


def parse_core_spec(spec: str) -> Core:
    """Parse ``cork:depth=10,d=1.0,ratio=0.33[,plug=1][,modulus=0]`` (inches) into a Core (SI).

    Kinds: cork (ratio 1/3), heavy (1.8), neutral (density-neutral soft fill, 1.0), core.
    """
    kind, _, rest = spec.partition(":")
    if kind not in FILL_DEFAULTS:
        raise ValueError(f"alteration {spec!r}: kind must be one of {', '.join(FILL_DEFAULTS)}")
    values = {"depth": 10.0, "d": 1.0, "ratio": FILL_DEFAULTS[kind], "plug": 1.0, "modulus": 0.0}
    for item in filter(None, rest.split(",")):
        key, eq, val = item.partition("=")
        if not eq or key.strip() not in values:
            raise ValueError(f"alteration {spec!r}: bad item {item!r}")
        try:
            values[key.strip()] = float(val)
        except ValueError:
            raise ValueError(f"alteration {spec!r}: {key} is not a number") from None
    return Core(values["d"] * IN_TO_M, values["depth"] * IN_TO_M, values["ratio"],
                values["modulus"], values["plug"] * IN_TO_M)
