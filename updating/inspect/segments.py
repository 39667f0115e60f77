"""A local change of the bat over one stretch of its length: the physics of every alteration.

A segment [x0, x1] (m from the knob end) changes each element e it covers, in the covered
share w_e of the element's length:

- non-structural mass (nails, wax, pine tar, tape): a mass ``added_mass_kg`` spread uniformly
  along the segment, mu = m / (x1 - x0) per metre, added to the element's translational mass
  as the fraction f_e = w_e L_e mu / m_e of its own consistent mass matrix (m_e = rho A_e L_e,
  the element's wood mass); it adds no stiffness;
- a loss of outer diameter ``diameter_loss_m`` = delta (shaved, flattened, grooved): with
  s_e = 1 - delta / D_e, translational mass and shear stiffness go with the area,
  s_e^2 - 1, bending stiffness and rotary inertia with the second moment, s_e^4 - 1 (a loss of
  1 % of the diameter takes 2 % of the mass and 4 % of the bending stiffness);
- relative changes of the wood's mass, bending and shear stiffness (``mass_rel``,
  ``bend_rel``, ``shear_rel``): the generic local change, alpha and beta of the paper's MSSO
  element factors (K = K_S + sum beta_i k_i, M = M_S + sum alpha_i m_i).

    dK = sum_e w_e (beta_b,e k_bend,e + beta_s,e k_shear,e)
    dM = sum_e (w_e alpha_e + f_e) m_trans,e + w_e alpha_rot,e m_rot,e

The covered share is continuous in x0 and x1, so a fit can move the segment smoothly.
Reference: ../../docs/inspection.md ("H1: a local change, then its kind").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.model.assembly import BatModel, place

MIN_DIAMETER_SHARE = 0.2
"""A diameter loss never takes a section below this share of its diameter."""


@dataclass(frozen=True)
class Segment:
    """One local change of the bat (module docstring).

    Parameters
    ----------
    x0_m, x1_m : float
        Where the change lies, m from the knob end (x0 < x1).
    added_mass_kg : float
        Non-structural mass spread uniformly over the segment, kg.
    diameter_loss_m : float
        Outer diameter removed over the segment, m.
    mass_rel, bend_rel, shear_rel : float
        Relative changes of the wood's mass (translational and rotary), bending stiffness
        and shear stiffness over the segment.
    """

    x0_m: float
    x1_m: float
    added_mass_kg: float = 0.0
    diameter_loss_m: float = 0.0
    mass_rel: float = 0.0
    bend_rel: float = 0.0
    shear_rel: float = 0.0


def coverage(node_x_m: np.ndarray, x0_m: float, x1_m: float) -> np.ndarray:
    """Share of each element's length inside [x0, x1], (e,), in [0, 1].

    Parameters
    ----------
    node_x_m : ndarray
        (e + 1,) node positions, m, increasing.
    x0_m, x1_m : float
        The segment, m.
    """
    lo, hi = node_x_m[:-1], node_x_m[1:]
    inside = np.clip(np.minimum(hi, x1_m) - np.maximum(lo, x0_m), 0.0, None)
    return inside / (hi - lo)


def element_masses_kg(model: BatModel) -> np.ndarray:
    """Translational mass of each element, t^T m_trans,e t with t the rigid translation, (e,)."""
    t = np.array([1.0, 0.0, 1.0, 0.0])
    return np.einsum("i,eij,j->e", t, model.parts.m_trans, t)


def element_diameters_m(model: BatModel) -> np.ndarray:
    """Outer diameter at each element's middle, m, (e,) (the model's profile)."""
    mid = 0.5 * (model.node_x_m[:-1] + model.node_x_m[1:])
    return np.asarray(model.profile.diameter_at(mid), dtype=float)


def segment_factors(model: BatModel, seg: Segment) -> dict[str, np.ndarray]:
    """Per-element factors of a segment: ``bend``, ``shear``, ``trans``, ``rot``, each (e,).

    Parameters
    ----------
    model : BatModel
        The wood model the segment changes (its profile gives the diameters).
    seg : Segment
        The change.

    Returns
    -------
    dict
        Factors f such that dK = place(k_bend, bend) + place(k_shear, shear) and
        dM = place(m_trans, trans) + place(m_rot, rot).
    """
    w = coverage(model.node_x_m, seg.x0_m, seg.x1_m)
    bend = w * seg.bend_rel
    shear = w * seg.shear_rel
    trans = w * seg.mass_rel
    rot = w * seg.mass_rel
    if seg.diameter_loss_m:
        s = np.clip(1.0 - seg.diameter_loss_m / element_diameters_m(model), MIN_DIAMETER_SHARE,
                    None)
        bend = bend + w * (s**4 - 1.0)
        shear = shear + w * (s**2 - 1.0)
        trans = trans + w * (s**2 - 1.0)
        rot = rot + w * (s**4 - 1.0)
    if seg.added_mass_kg:
        length = seg.x1_m - seg.x0_m
        mu = seg.added_mass_kg / length if length > 0 else 0.0
        trans = trans + w * model.element_length_m * mu / element_masses_kg(model)
    return {"bend": bend, "shear": shear, "trans": trans, "rot": rot}


def segment_matrices(model: BatModel, segments) -> tuple[np.ndarray, np.ndarray] | None:
    """(dK, dM) of the segments on the model's wood matrices, or None for no segment.

    Parameters
    ----------
    model : BatModel
        The wood model.
    segments : iterable of Segment
        The changes (their effects add).
    """
    segs = tuple(segments)
    if not segs:
        return None
    total = {k: np.zeros(model.n_elements) for k in ("bend", "shear", "trans", "rot")}
    for seg in segs:
        for k, v in segment_factors(model, seg).items():
            total[k] += v
    p = model.parts
    dK = place(model, p.k_bend, total["bend"]) + place(model, p.k_shear, total["shear"])
    dM = place(model, p.m_trans, total["trans"]) + place(model, p.m_rot, total["rot"])
    return dK, dM


def segment_mass_kg(model: BatModel, segments) -> float:
    """Change of the bat's mass on a scale from the segments, kg (added and removed)."""
    m_el = element_masses_kg(model)
    return float(sum(np.sum(segment_factors(model, s)["trans"] * m_el) for s in segments))
