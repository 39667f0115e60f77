"""The pre-test summary of a model in lab units, as `batlab model` prints it."""

from __future__ import annotations

import numpy as np

from updating.model.assembly import BatModel
from updating.model.mass_properties import mass_properties
from updating.model.modes import model_modes
from updating.model.placement import effective_independence
from updating.model.units import KG_M2_TO_LB_IN2, LB_TO_KG, m_to_in


def summarise_model(model: BatModel, n_modes: int = 8, n_points: int = 16) -> dict:
    """ndof, weight, centre of mass, inertias, the lowest frequencies and EfI test points."""
    mp = mass_properties(model)
    modes = model_modes(model, n_modes=min(n_modes, model.n_dof))
    elastic = modes.elastic()
    targets = elastic.shapes[model.translational_dofs, : min(4, elastic.freq_hz.size)]
    n_pts = min(max(n_points, targets.shape[1]), model.n_nodes)
    keep = effective_independence(targets, n_pts)
    return {
        "ndof": model.n_dof,
        "n_elements": model.n_elements,
        "beam": model.beam,
        "weight_lb": mp.mass_kg / LB_TO_KG,
        "cg_in": m_to_in(mp.cg_m),
        "moi_knob_lb_in2": mp.i_knob_kg_m2 * KG_M2_TO_LB_IN2,
        "moi_cg_lb_in2": mp.i_cg_kg_m2 * KG_M2_TO_LB_IN2,
        "frequencies_hz": [float(f) for f in modes.freq_hz],
        "suggested_points_in": [float(x) for x in np.round(m_to_in(model.node_x_m[keep]), 3)],
    }
