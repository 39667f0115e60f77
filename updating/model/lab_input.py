"""A bat's lab inputs (meta.json) turned into model inputs, and alteration specs.

meta.json (docs/contract.md): serial, species, nominal_E_psi,
nominal_weight_density_lbf_in3, weight_lb, points_in; the optional accelerometer_mass_g (the
accelerometer's data sheet, used by diagnose as a prior); other keys are ignored.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ema.io.finite import finite_number
from updating.model.json_input import read_json_object
from updating.model.material import ISOTROPIC_E_OVER_G, Material, material_from_imperial
from updating.model.sections import Core
from updating.model.units import IN_TO_M, LB_TO_KG

META_RANGES = {  # key: (lowest, highest) accepted, in the file's units; wider than any bat
    "nominal_E_psi": (1e4, 1e8),
    "nominal_weight_density_lbf_in3": (1e-4, 1.0),
    "weight_lb": (0.05, 50.0),
    "points_in": (-10.0, 100.0),
}


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
        The registered weight, kg.
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
    """Read meta.json; raise ValueError naming the file and the missing/bad key."""
    path = Path(path)
    raw = read_json_object(path)
    for key in ("serial", "nominal_E_psi", "nominal_weight_density_lbf_in3"):
        if key not in raw:
            raise ValueError(f"{path}: missing key {key!r}")

    def scalar(key: str) -> float:
        lo, hi = META_RANGES.get(key, (-np.inf, np.inf))
        return finite_number(raw[key], f"{path}: key {key!r}", lo, hi)

    E = scalar("nominal_E_psi")
    wd = scalar("nominal_weight_density_lbf_in3")
    weight_kg = None if raw.get("weight_lb") is None else scalar("weight_lb") * LB_TO_KG
    try:
        points = np.asarray(raw.get("points_in", []), dtype=float).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{path}: key 'points_in' must be a list of numbers (inches from the "
                         "knob end)") from None
    for k, x in enumerate(points):
        finite_number(x, f"{path}: key 'points_in'[{k}]", *META_RANGES["points_in"])
    points = points * IN_TO_M
    if E <= 0 or wd <= 0 or (weight_kg is not None and weight_kg <= 0):
        raise ValueError(f"{path}: modulus, density and weight must be positive")
    sensor_kg = None
    if raw.get("accelerometer_mass_g") is not None:
        sensor_g = scalar("accelerometer_mass_g")
        if not 0.0 <= sensor_g <= 100.0:
            raise ValueError(f"{path}: key 'accelerometer_mass_g' = {sensor_g:g} is outside "
                             "0-100 g")
        sensor_kg = 1e-3 * sensor_g
    return BatMeta(str(raw["serial"]), str(raw.get("species", "")),
                   material_from_imperial(E, wd, e_over_g), weight_kg, points, raw, sensor_kg)


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
