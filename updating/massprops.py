"""Mass properties of the bat model, from the same section quadrature as the mass matrix.

    m = int rhoA dx,  x_cg = int rhoA x dx / m,  I_knob = int (rhoA x^2 + rhoI) dx,
    I_cg = I_knob - m x_cg^2   (about a transverse axis; point masses added).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.fe_model import BatModel


@dataclass(frozen=True)
class MassProperties:
    mass_kg: float
    cg_m: float
    i_knob_kg_m2: float
    i_cg_kg_m2: float


def mass_properties(model: BatModel, with_attachments: bool = False) -> MassProperties:
    """Mass, centre of mass and transverse moments of inertia (rotary inertia always counted)."""
    s = model.samples
    w, x = s.weight_m, s.x_m
    m = float(np.sum(w * s.props.rhoa))
    mx = float(np.sum(w * s.props.rhoa * x))
    i0 = float(np.sum(w * (s.props.rhoa * x**2 + s.props.rhoi)))
    if with_attachments:
        for a in model.attachments:
            m, mx, i0 = m + a.mass_kg, mx + a.mass_kg * a.x_m, i0 + a.mass_kg * a.x_m**2
    cg = mx / m
    return MassProperties(m, cg, i0, i0 - m * cg**2)
