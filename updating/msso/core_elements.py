"""Element mass and stiffness factors implied by a physical core (the quantities MSSO estimates).

For element i of the reference mesh, with section properties averaged over the element,

    alpha_i = <rhoA>_cored / <rhoA>_ref - 1      (translational mass)
    beta_i  = <EI>_cored / <EI>_ref - 1          (bending stiffness)
    beta_shear_i = <kGA>_cored / <kGA>_ref - 1   (shear stiffness)

so that a fully cored element of outer diameter D reads alpha = (r - 1)(d/D)^2 and
beta = -(d/D)^4 (docs/method.md), and a partly cored element the overlap-weighted value.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.model.assembly import BatModel, sample_sections
from updating.model.sections import Core


@dataclass(frozen=True)
class CoreFactors:
    """Element factors a physical core implies on the reference mesh.

    The truth an MSSO result (``msso.factors.ElementFactors``, the unknowns) is compared with:
    (e,) arrays, one entry per element.

    Attributes
    ----------
    x0_m, x1_m : ndarray
        The elements' ends, m.
    alpha, beta, beta_shear : ndarray
        Translational mass, bending stiffness and shear stiffness factors.
    """

    x0_m: np.ndarray
    x1_m: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    beta_shear: np.ndarray


def core_element_factors(model: BatModel, core: Core | None) -> CoreFactors:
    """Factors of ``core`` on the mesh of ``model`` (built from a profile and material)."""
    x = model.node_x_m
    n = model.n_elements
    if core is None:
        z = np.zeros(n)
        return CoreFactors(x[:-1], x[1:], z, z.copy(), z.copy())
    ref = sample_sections(x, model.profile, model.material, None)
    cored = sample_sections(x, model.profile, model.material, core)

    def avg(s, v):
        return np.bincount(s.elem, s.weight_m * v, n)

    return CoreFactors(
        x[:-1], x[1:],
        alpha=avg(cored, cored.props.rhoa) / avg(ref, ref.props.rhoa) - 1,
        beta=avg(cored, cored.props.ei) / avg(ref, ref.props.ei) - 1,
        beta_shear=avg(cored, cored.props.kga) / avg(ref, ref.props.kga) - 1,
    )
