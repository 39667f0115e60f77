"""The pre-test summary of a model in lab units, as `batlab model` prints it."""

from __future__ import annotations

import numpy as np

from updating.model.assembly import BatModel, displacement_at
from updating.model.mass_properties import mass_properties
from updating.model.modes import model_modes
from updating.model.placement import suggest_points
from updating.model.units import KG_M2_TO_LB_IN2, LB_TO_KG, m_to_in


def summarise_model(model: BatModel, n_modes: int = 8, n_points: int = 16) -> dict:
    """ndof, weight, centre of mass, inertias, the lowest frequencies and the suggested test
    points (barrel row plus EfI, ``updating.model.placement.suggest_points``)."""
    mp = mass_properties(model)
    modes = model_modes(model, n_modes=min(n_modes, model.n_dof))
    elastic = modes.elastic()
    targets = elastic.shapes[:, : min(4, elastic.freq_hz.size)]
    layout = suggest_points(model.node_x_m[-1], lambda x: displacement_at(model, targets, x),
                            n_points, targets.shape[1])
    return {
        "ndof": model.n_dof,
        "n_elements": model.n_elements,
        "beam": model.beam,
        "weight_lb": mp.mass_kg / LB_TO_KG,
        "cg_in": m_to_in(mp.cg_m),
        "moi_knob_lb_in2": mp.i_knob_kg_m2 * KG_M2_TO_LB_IN2,
        "moi_cg_lb_in2": mp.i_cg_kg_m2 * KG_M2_TO_LB_IN2,
        "frequencies_hz": [float(f) for f in modes.freq_hz],
        "suggested_points_in": [float(x) for x in np.round(m_to_in(layout.points_m), 3)],
        "driving_point_in": float(np.round(m_to_in(layout.driving_point_m), 3)),
    }
