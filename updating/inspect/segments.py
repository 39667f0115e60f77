"""A local change of the bat over one stretch of its length: the physics of every alteration.

A segment [x0, x1] (m from the knob end) changes the section properties along it, and the
changes are integrated exactly over the covered part of each element, with the element's own
shape functions (Gauss-Legendre on the sub-interval [max(x0, x_e), min(x1, x_e+1)]):

    dK_e = int (dEI kappa kappa^T + dkGA gamma gamma^T) dx
    dM_e = int (drhoA N_w N_w^T + drhoI N_theta N_theta^T) dx

- non-structural mass (nails, wax, pine tar, tape): ``added_mass_kg`` spread along the
  segment, uniformly for an insert on the axis, or per metre in proportion to D for a layer
  of even thickness on the surface, which also adds the rotary inertia of a thin ring,
  mu D^2 / 8 per metre; no stiffness;
- a loss of outer diameter ``diameter_loss_m`` = delta (shaved, flattened, grooved): with
  s = 1 - delta / D, rhoA and kGA scale by s^2, EI and rhoI by s^4 (1 % of the diameter takes
  2 % of the mass and 4 % of the bending stiffness);
- relative changes of the wood's mass, bending and shear stiffness (``mass_rel``,
  ``bend_rel``, ``shear_rel``): the generic local change; over whole elements, alpha and
  beta of the paper's MSSO element factors (K = K_S + sum beta_i k_i, M = M_S + sum alpha_i
  m_i).

The integration follows the segment's ends smoothly, so a fit can move them. It is the
fast, element-wise counterpart of ``updating.model.local_change`` (which rebuilds a model's
sections for the virtual rig); both give the same matrices on a mesh with nodes at the
segment's ends (tests/test_local_change.py).
Reference: ../../docs/kinds.md ("H1: a local change, then its kind").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.model.assembly import BatModel, add_element_blocks, gauss_legendre
from updating.model.element import ElementParts, element_parts
from updating.model.sections import section_props
from updating.msso.core_elements import CoreFactors, core_element_factors

MIN_DIAMETER_SHARE = 0.2
"""A diameter loss never takes a section below this share of its diameter."""
N_GAUSS = 4
"""Gauss points per covered element: exact for the cubic shape functions' products."""
GAUSS_POINTS = gauss_legendre(N_GAUSS)
"""Gauss-Legendre points and weights on [-1, 1] (computed once: a fit integrates thousands of
segments)."""


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
    mass_at_surface : bool
        The added mass is a layer on the surface (pine tar, tape, wax): its mass per metre
        goes with the diameter D and it adds the rotary inertia of a thin ring, mu D^2 / 8
        per metre; else an insert on the axis, uniform, with no rotary inertia.
    """

    x0_m: float
    x1_m: float
    added_mass_kg: float = 0.0
    diameter_loss_m: float = 0.0
    mass_rel: float = 0.0
    bend_rel: float = 0.0
    shear_rel: float = 0.0
    mass_at_surface: bool = False


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
    """Return each element's translational mass, t^T m_trans,e t (t: rigid translation), (e,)."""
    t = np.array([1.0, 0.0, 1.0, 0.0])
    return np.einsum("i,eij,j->e", t, model.parts.m_trans, t)


def segment_parts(model: BatModel, seg: Segment) -> tuple[ElementParts, float]:
    """Integrate a segment's change into element parts, and its change of mass, kg.

    Parameters
    ----------
    model : BatModel
        The wood model the segment changes (its profile and material give the sections).
    seg : Segment
        The change.

    Returns
    -------
    parts : ElementParts
        dK and dM of each element in parts (bending, shear, translation, rotation).
    mass_kg : float
        int drhoA dx: the change of the bat's mass on a scale.
    """
    parts, mass = segments_parts(model, (seg,))
    return ElementParts(parts.k_bend[0], parts.k_shear[0], parts.m_trans[0],
                        parts.m_rot[0]), float(mass[0])


def segments_parts(model: BatModel, segments) -> tuple[ElementParts, np.ndarray]:
    """Integrate k segments' changes, each alone, in one pass over all their samples.

    The module docstring's integrals for every segment at once (a Jacobian steps several
    segments): each segment's samples and element parts are the ones it would get alone,
    bit for bit (its sums over its own samples, in their order).

    Parameters
    ----------
    model : BatModel
        The wood model the segments change.
    segments : sequence of Segment
        The changes.

    Returns
    -------
    parts : ElementParts
        (k, e, 4, 4) each segment's element parts.
    mass_kg : numpy.ndarray
        (k,) each segment's int drhoA dx, kg.
    """
    segs = tuple(segments)
    k = len(segs)
    nodes = model.node_x_m
    n_el = nodes.size - 1

    def each(name: str) -> np.ndarray:
        return np.array([float(getattr(seg, name)) for seg in segs])

    a = np.maximum(nodes[None, :-1], each("x0_m")[:, None])
    b = np.minimum(nodes[None, 1:], each("x1_m")[:, None])
    sid, elem = np.nonzero(b > a)  # segment by segment, elements ascending
    g, gw = GAUSS_POINTS
    half = 0.5 * (b[sid, elem] - a[sid, elem])
    x = ((a[sid, elem] + half)[:, None] + half[:, None] * g[None, :]).ravel()
    w = (half[:, None] * gw[None, :]).ravel()
    sid, elem = np.repeat(sid, N_GAUSS), np.repeat(elem, N_GAUSS)
    bounds = np.searchsorted(sid, np.arange(k + 1))
    L = np.diff(nodes)
    D = np.asarray(model.profile.diameter_at(x), dtype=float)
    wood = section_props(D, model.material)
    d_ei = each("bend_rel")[sid] * wood.ei
    d_kga = each("shear_rel")[sid] * wood.kga
    d_rhoa = each("mass_rel")[sid] * wood.rhoa
    d_rhoi = each("mass_rel")[sid] * wood.rhoi
    for i, seg in enumerate(segs):
        sl = slice(bounds[i], bounds[i + 1])
        if seg.diameter_loss_m:
            s = np.clip(1.0 - seg.diameter_loss_m / D[sl], MIN_DIAMETER_SHARE, None)
            d_ei[sl] = d_ei[sl] + wood.ei[sl] * (s**4 - 1.0)
            d_kga[sl] = d_kga[sl] + wood.kga[sl] * (s**2 - 1.0)
            d_rhoa[sl] = d_rhoa[sl] + wood.rhoa[sl] * (s**2 - 1.0)
            d_rhoi[sl] = d_rhoi[sl] + wood.rhoi[sl] * (s**4 - 1.0)
        if seg.added_mass_kg and sl.stop > sl.start:
            shape = D[sl] if seg.mass_at_surface else np.ones_like(D[sl])
            mu = seg.added_mass_kg * shape / float(np.sum(w[sl] * shape))
            d_rhoa[sl] = d_rhoa[sl] + mu
            if seg.mass_at_surface:
                d_rhoi[sl] = d_rhoi[sl] + mu * D[sl] ** 2 / 8
    if not model.rotary_inertia:
        d_rhoi = np.zeros_like(d_rhoi)
    flat = element_parts(sid * n_el + elem, (x - nodes[elem]) / L[elem], w, d_ei, d_kga,
                         d_rhoa, d_rhoi, np.tile(L, k), np.tile(model.phi, k))
    parts = ElementParts(*(getattr(flat, f).reshape(k, n_el, 4, 4)
                           for f in ("k_bend", "k_shear", "m_trans", "m_rot")))
    mass = np.array([float(np.sum(w[bounds[i]:bounds[i + 1]] * d_rhoa[bounds[i]:bounds[i + 1]]))
                     for i in range(k)])
    return parts, mass


def segment_change(model: BatModel, segments) -> tuple[np.ndarray, np.ndarray, float]:
    """(dK, dM, mass change in kg) of the segments on the model's wood matrices.

    Parameters
    ----------
    model : BatModel
        The wood model.
    segments : iterable of Segment
        The changes (their effects add).
    """
    dK = np.zeros((model.n_dof, model.n_dof))
    dM = np.zeros_like(dK)
    mass = 0.0
    for seg in segments:
        p, m = segment_parts(model, seg)
        touched = np.flatnonzero(np.any(p.m_trans != 0, axis=(1, 2))
                                 | np.any(p.k_bend != 0, axis=(1, 2))
                                 | np.any(p.k_shear != 0, axis=(1, 2)))
        d = model.dofs[touched]
        at = (d[:, :, None], d[:, None, :])
        np.add.at(dK, at, (p.k_bend + p.k_shear)[touched])
        np.add.at(dM, at, (p.m_trans + p.m_rot)[touched])
        mass += m
    return dK, dM, mass


def segment_changes(model: BatModel, segments) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(dK, dM, mass change in kg) of each segment alone, (k, N, N) twice and (k,).

    ``segment_change(model, (seg,))`` for each segment, bit for bit, integrated in one pass
    (``segments_parts``). Every entry of dK or dM gets at most two elements' terms, so the
    order they are placed in does not change the sum.
    """
    parts, mass = segments_parts(model, segments)
    k, n = mass.size, model.n_dof
    dK = add_element_blocks(np.zeros((k, n, n)), parts.k_bend + parts.k_shear)
    dM = add_element_blocks(np.zeros((k, n, n)), parts.m_trans + parts.m_rot)
    return dK, dM, mass


def segment_matrices(model: BatModel, segments) -> tuple[np.ndarray, np.ndarray] | None:
    """(dK, dM) of the segments on the model's wood matrices, or None for no segment."""
    segs = tuple(segments)
    return None if not segs else segment_change(model, segs)[:2]


def segment_mass_kg(model: BatModel, segments) -> float:
    """Change of the bat's mass on a scale from the segments, kg (added and removed)."""
    return float(sum(segment_parts(model, s)[1] for s in segments))


def element_factors(model: BatModel, params) -> CoreFactors:
    """Element mass and stiffness factors of a fitted state's local changes (MSSO's alpha, beta).

    A core's factors (``core_element_factors``) plus each segment's: the change of each
    element's translational mass, alpha_e = t^T dm_e t / t^T m_e t, and of its bending and
    shear stiffness, beta_e = <dk_e, k_e> / <k_e, k_e> (Frobenius), which is the factor itself
    where the change covers the whole element.

    Parameters
    ----------
    model : BatModel
        The wood model (the reference mesh at the test points).
    params : ChangeParams or None
        The fitted state, or None for no change.

    Returns
    -------
    CoreFactors
        Element ends and factors, (e,) each.
    """
    core = None if params is None else params.core
    out = core_element_factors(model, core)
    if params is None or not params.segments:
        return out
    t = np.array([1.0, 0.0, 1.0, 0.0])
    p = model.parts
    alpha, beta, beta_s = out.alpha.copy(), out.beta.copy(), out.beta_shear.copy()
    for seg in params.segments:
        d, _ = segment_parts(model, seg)
        alpha += np.einsum("i,eij,j->e", t, d.m_trans, t) / element_masses_kg(model)
        beta += _frobenius_ratio(d.k_bend, p.k_bend)
        beta_s += _frobenius_ratio(d.k_shear, p.k_shear)
    return CoreFactors(out.x0_m, out.x1_m, alpha, beta, beta_s)


def _frobenius_ratio(d: np.ndarray, k: np.ndarray) -> np.ndarray:
    """<d_e, k_e> / <k_e, k_e> per element (0 where k_e vanishes)."""
    num = np.einsum("eij,eij->e", d, k)
    den = np.einsum("eij,eij->e", k, k)
    return np.divide(num, den, out=np.zeros_like(num), where=den > 0)
