"""Cavities besides the model's one core: a cupped barrel end, the empty part of a partial fill.

``build_model`` takes a single ``Core`` (which can leave its hole's outer stretch empty,
``Core.empty_m``). A real bat can have more: the cup turned into the barrel end (up to 1 in
deep, MLB rules) besides a core. The simulator also builds a partial fill's empty stretch as
a cavity here, independently of ``Core.empty_m`` (a test compares the two). Each cavity is a
``Core`` (diameter, depth from the barrel end, fill density and modulus ratios, plug: its
distance from the barrel end; a cup has plug 0). At the quadrature samples inside a cavity
the section is recomputed with ``section_props`` (annulus of wood plus fill, Cowper's tube
coefficient). The mesh must have nodes at the cavities' ends (``cavity_stations_m``) so that
every sample lies wholly on one side of them.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from updating.model.assembly import BatModel, parts_from_samples
from updating.model.material import Material
from updating.model.sections import Core, SectionProps, section_props


def cavity_interval_m(cavity: Core, length_m: float) -> tuple[float, float]:
    """(start, end) of a cavity along the bat, m from the knob end."""
    return length_m - cavity.depth_m, length_m - cavity.plug_m


def cavity_stations_m(cavities: tuple[Core, ...], length_m: float) -> np.ndarray:
    """Where the mesh needs nodes: both ends of every cavity that lies inside the bat."""
    ends = [cavity_interval_m(c, length_m) for c in cavities]
    st = np.array([x for pair in ends for x in pair], dtype=float)
    return st[(st > 0) & (st < length_m)]


def apply_cavities(model: BatModel, material: Material, cavities: tuple[Core, ...]) -> BatModel:
    """Recompute the model's sections in each cavity (exact for nodes at the cavity ends)."""
    if not cavities:
        return model
    profile = model.profile
    s = model.samples
    p = [np.array(v, dtype=float) for v in (s.props.ei, s.props.kga, s.props.rhoa, s.props.rhoi)]
    for cav in cavities:
        x0, x1 = cavity_interval_m(cav, profile.length_m)
        inside = (s.x_m > x0) & (s.x_m < x1)
        if not inside.any():
            continue
        new = section_props(profile.diameter_at(s.x_m[inside]), material, cav.diameter_m,
                            cav.fill_density_ratio, cav.fill_modulus_ratio)
        for arr, v in zip(p, (new.ei, new.kga, new.rhoa, new.rhoi), strict=True):
            arr[inside] = v
    samples = replace(s, props=SectionProps(*p))
    phi, parts = parts_from_samples(model.node_x_m, samples, model.beam, model.rotary_inertia)
    return replace(model, samples=samples, phi=phi, parts=parts)
