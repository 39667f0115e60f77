"""A reference bar for checking a test rig: uniform round, tube or rectangular section, SI.

Labs check their set-up on an artefact of known material and geometry (a steel or aluminium
bar). The bar is a uniform free-free Timoshenko beam with rotary inertia (the same elements
as the bat, updating.model.element). Section properties, h the dimension along the tap:

    round / tube (outer D, inner d): A = pi/4 (D^2 - d^2), I = pi/64 (D^4 - d^4),
        k Hutchinson's (updating.model.sections; closest to a 3D solid, docs/model.md);
    rectangular (width b across the tap, height h along it): A = b h, I = b h^3 / 12,
        k = 10 (1 + nu) / (12 + 11 nu) (Cowper 1966).

Bar description file (JSON; every length key says its unit, `_mm` or `_m`):

    {"material": {"E_gpa": 200, "density_kg_m3": 7850, "nu": 0.29},
     "length_mm": 600,
     "section": {"shape": "tube", "diameter_mm": 25.4, "inner_diameter_mm": 19.0},
     "sensor_mass_g": 2.0}

`E_pa` may replace `E_gpa`; a rectangular section has `width_*` and `height_*`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from updating.model.assembly import Attachment, BatModel, build_model, parts_from_samples
from updating.model.json_input import read_json_object
from updating.model.material import Material
from updating.model.profile import make_profile
from updating.model.sections import SectionProps, section_props

SHAPES = ("round", "tube", "rectangular")


@dataclass(frozen=True)
class Bar:
    """A reference bar, SI. height_m: section depth along the tap (rectangular)."""

    material: Material
    length_m: float
    shape: str
    diameter_m: float = 0.0
    inner_diameter_m: float = 0.0
    width_m: float = 0.0
    height_m: float = 0.0
    sensor_mass_kg: float = 0.0

    def section(self) -> SectionProps:
        """Section properties (scalars as 0-d arrays)."""
        m = self.material
        if self.shape in ("round", "tube"):
            return section_props(np.array(self.diameter_m), m, self.inner_diameter_m)
        if self.shape == "rectangular":
            b, h = self.width_m, self.height_m
            a, i = b * h, b * h**3 / 12
            k = 10 * (1 + m.nu) / (12 + 11 * m.nu)
            return SectionProps(np.array(m.E_pa * i), np.array(k * m.G_pa * a),
                                np.array(m.rho_kg_m3 * a), np.array(m.rho_kg_m3 * i))
        raise ValueError(f"unknown section shape {self.shape!r} ({', '.join(SHAPES)})")

    @property
    def mass_kg(self) -> float:
        """Return the bar's mass, kg (attachments excluded)."""
        return float(self.section().rhoa) * self.length_m

    def model(self, n_elements: int = 60, stations_m=(), sensor_x_m: float | None = None
              ) -> BatModel:
        """Build the bar's free-free Timoshenko model, with the accelerometer at sensor_x_m."""
        L = self.length_m
        att = ()
        if self.sensor_mass_kg and sensor_x_m is not None:
            att = (Attachment(float(sensor_x_m), mass_kg=self.sensor_mass_kg),)
        stand_in = make_profile(np.array([0.0, L]), np.array([1.0, 1.0]) * L / 10, "bar")
        model = build_model(stand_in, self.material, beam="timoshenko", rotary_inertia=True,
                            n_elements=n_elements, stations_m=stations_m, attachments=att)
        s = model.samples
        sec = self.section()
        props = SectionProps(*(np.full(s.x_m.shape, float(v)) for v in
                               (sec.ei, sec.kga, sec.rhoa, sec.rhoi)))
        samples = replace(s, props=props)
        phi, parts = parts_from_samples(model.node_x_m, samples, "timoshenko", True)
        return replace(model, samples=samples, phi=phi, parts=parts, profile=None)


def _length(d: dict, key: str, source: str, required: bool = True) -> float:
    for unit, f in (("_mm", 1e-3), ("_m", 1.0)):
        if key + unit in d:
            v = d[key + unit]
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not v > 0:
                raise ValueError(f"{source}: {key + unit} must be a positive number")
            return float(v) * f
    if required:
        raise ValueError(f"{source}: missing {key}_mm or {key}_m")
    return 0.0


def _number(d: dict, key: str, source: str) -> float:
    v = d.get(key)
    if not isinstance(v, (int, float)) or isinstance(v, bool) or not v > 0:
        raise ValueError(f"{source}: {key} must be a positive number")
    return float(v)


def bar_from_dict(d: dict, source: str = "bar") -> Bar:
    """Validate a bar description (module docstring); ValueError naming the key."""
    mat = d.get("material")
    if not isinstance(mat, dict):
        raise ValueError(f"{source}: missing object 'material'")
    if "E_gpa" in mat:
        E = _number(mat, "E_gpa", f"{source}: material") * 1e9
    else:
        E = _number(mat, "E_pa", f"{source}: material (E_pa or E_gpa)")
    rho = _number(mat, "density_kg_m3", f"{source}: material")
    nu = float(mat.get("nu", 0.3))
    if not 0 <= nu < 0.5:
        raise ValueError(f"{source}: material nu must be in [0, 0.5)")
    material = Material(E, rho, 2 * (1 + nu), nu, "hutchinson")
    sec = d.get("section")
    if not isinstance(sec, dict) or sec.get("shape") not in SHAPES:
        raise ValueError(f"{source}: section.shape must be one of {', '.join(SHAPES)}")
    shape = sec["shape"]
    length = _length(d, "length", source)
    sensor = d.get("sensor_mass_g", 0.0)
    if not isinstance(sensor, (int, float)) or sensor < 0:
        raise ValueError(f"{source}: sensor_mass_g must be a number >= 0")
    kw = {}
    if shape in ("round", "tube"):
        kw["diameter_m"] = _length(sec, "diameter", f"{source}: section")
        if shape == "tube":
            kw["inner_diameter_m"] = _length(sec, "inner_diameter", f"{source}: section")
            if kw["inner_diameter_m"] >= kw["diameter_m"]:
                raise ValueError(f"{source}: section inner_diameter must be below diameter")
    else:
        kw["width_m"] = _length(sec, "width", f"{source}: section")
        kw["height_m"] = _length(sec, "height", f"{source}: section")
    return Bar(material, length, shape, sensor_mass_kg=float(sensor) * 1e-3, **kw)


def read_bar_json(path: str | Path) -> Bar:
    """Read a bar description file."""
    path = Path(path)
    return bar_from_dict(read_json_object(path), str(path))
