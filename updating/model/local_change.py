"""Local changes of a bat's sections: non-structural mass, a diameter lost, a flat planed on.

A ``LocalChange`` acts on the stretch [x0, x1] from the knob end. ``apply_local_changes``
changes the model's section properties at every quadrature sample inside it, as factors and
additions on what is there (wood field, cavities and core included):

- outer diameter D turned down by ``diameter_loss_m`` (shaved, grooved): with r = D'/D,
  rhoA and kGA x r^2, EI and rhoI x r^4 (a solid section: A ~ D^2, I ~ D^4);
- one side planed flat, ``flat_depth_m`` deep (a circular segment of height h cut from a
  circle of radius R, half-angle a, cos a = 1 - h/R):

      A_s = R^2 (a - sin a cos a),   Q_s = 2/3 R^3 sin^3 a,
      I_n,s = R^4/4 (a - sin a cos a + 2 sin^3 a cos a),
      I_p,s = R^4/12 (3a - 3 sin a cos a - 2 sin^3 a cos a)

  about the centre's axes parallel (n: bending towards the flat) and normal (p) to the flat;
  the rest has A = pi R^2 - A_s, centroid y_c = -Q_s / A, I_n = pi R^4/4 - I_n,s - A y_c^2,
  I_p = pi R^4/4 - I_p,s. A bending plane at angle psi to the flat's normal sees
  I_n cos^2 psi + I_p sin^2 psi (the cross term of an oblique plane is neglected);
- ``added_mass_kg`` of non-structural mass (nails, a coat, tape, pine tar) spread over the
  stretch, per unit length in proportion to D (a coat of even thickness) when
  ``mass_at_surface``, else uniformly (inserts on the axis); a surface layer adds rotary
  inertia mu D^2 / 8 (a thin ring), an insert none;
- ``added_ei_n_m2`` of bending stiffness (a bonded insert; 0 for a loose one).

The mesh needs nodes at x0 and x1 (``change_stations_m``) for the change to be integrated
exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from updating.model.assembly import BatModel, parts_from_samples
from updating.model.sections import SectionProps


@dataclass(frozen=True)
class LocalChange:
    """A change of the bat's sections over [x0_m, x1_m] (see the module's description).

    Attributes
    ----------
    x0_m, x1_m : float
        Start and end of the changed stretch from the knob end, m.
    added_mass_kg : float
        Non-structural mass spread over the stretch, kg (net of any wood it replaces).
    mass_at_surface : bool
        True: a layer on the surface (mass per length ~ D, rotary inertia mu D^2/8);
        False: an insert near the axis (uniform, no rotary inertia).
    added_ei_n_m2 : float
        Bending stiffness added over the stretch, N m^2.
    diameter_loss_m : float
        Outer diameter turned off, m.
    flat_depth_m : float
        Depth of a flat planed on one side, m.
    flat_angle_deg : float
        Angle of the flat's normal to the radial bending plane, degrees.
    """

    x0_m: float
    x1_m: float
    added_mass_kg: float = 0.0
    mass_at_surface: bool = True
    added_ei_n_m2: float = 0.0
    diameter_loss_m: float = 0.0
    flat_depth_m: float = 0.0
    flat_angle_deg: float = 0.0


def flat_section(radius_m: np.ndarray, depth_m: float) -> tuple[np.ndarray, ...]:
    """Compute a circle's section with a flat of ``depth_m`` planed on one side.

    Parameters
    ----------
    radius_m : ndarray
        Radius of the round section, m.
    depth_m : float
        Height of the circular segment cut off, m (0 <= depth < radius).

    Returns
    -------
    area_m2, i_normal_m4, i_parallel_m4 : ndarray
        Area and second moments about the centroid's axes parallel to the flat (bending
        towards the flat) and normal to it.
    """
    R = np.asarray(radius_m, dtype=float)
    a = np.arccos(np.clip(1.0 - depth_m / R, -1.0, 1.0))
    s, c = np.sin(a), np.cos(a)
    a_seg = R**2 * (a - s * c)
    q_seg = 2.0 / 3.0 * R**3 * s**3
    area = np.pi * R**2 - a_seg
    y_c = q_seg / area
    i_n = np.pi * R**4 / 4 - R**4 / 4 * (a - s * c + 2 * s**3 * c) - area * y_c**2
    i_p = np.pi * R**4 / 4 - R**4 / 12 * (3 * a - 3 * s * c - 2 * s**3 * c)
    return area, i_n, i_p


def section_factors(
    D_m: np.ndarray, change: LocalChange, plane: str,
) -> tuple[np.ndarray, np.ndarray]:
    """Return (area factor, second-moment factor) of ``change``'s material removal.

    Parameters
    ----------
    D_m : ndarray
        Outer diameter at the samples, m.
    change : LocalChange
        The change (its diameter loss and flat).
    plane : str
        "radial" or "tangential": the bending plane whose second moment is wanted.

    Returns
    -------
    area_factor, inertia_factor : ndarray
        A'/A and I'/I of the solid round section.
    """
    D = np.asarray(D_m, dtype=float)
    if change.diameter_loss_m >= np.min(D, initial=np.inf):
        raise ValueError("a diameter loss must be smaller than the diameter")
    r = (D - change.diameter_loss_m) / D
    area_f, inertia_f = r**2, r**4
    if change.flat_depth_m > 0.0:
        R = 0.5 * (D - change.diameter_loss_m)
        area, i_n, i_p = flat_section(R, change.flat_depth_m)
        psi = np.radians(change.flat_angle_deg + (90.0 if plane == "tangential" else 0.0))
        i_plane = i_n * np.cos(psi) ** 2 + i_p * np.sin(psi) ** 2
        area_f = area_f * area / (np.pi * R**2)
        inertia_f = inertia_f * i_plane / (np.pi * R**4 / 4)
    return area_f, inertia_f


def change_stations_m(changes: tuple[LocalChange, ...], length_m: float) -> np.ndarray:
    """Return where the mesh needs nodes: both ends of every change inside the bat, m."""
    st = np.array([x for c in changes for x in (c.x0_m, c.x1_m)], dtype=float)
    return st[(st > 0) & (st < length_m)]


def _one_change(model: BatModel, props: list[np.ndarray], change: LocalChange,
                plane: str) -> None:
    """Apply one change to the sample arrays ``props`` (ei, kga, rhoa, rhoi) in place."""
    s = model.samples
    inside = (s.x_m > change.x0_m) & (s.x_m < change.x1_m)
    if not inside.any():
        return
    D = model.profile.diameter_at(s.x_m[inside])
    area_f, inertia_f = section_factors(D, change, plane)
    props[0][inside] = props[0][inside] * inertia_f + change.added_ei_n_m2
    props[1][inside] *= area_f
    props[2][inside] *= area_f
    props[3][inside] *= inertia_f
    if change.added_mass_kg:
        D_out = D - change.diameter_loss_m
        shape = D_out if change.mass_at_surface else np.ones_like(D_out)
        mu = change.added_mass_kg * shape / np.sum(s.weight_m[inside] * shape)
        props[2][inside] += mu
        if change.mass_at_surface:
            props[3][inside] += mu * D_out**2 / 8


def apply_local_changes(
    model: BatModel, changes: tuple[LocalChange, ...], plane: str = "radial",
) -> BatModel:
    """Return the model with each change applied to its sections, rebuilt exactly.

    Parameters
    ----------
    model : BatModel
        A model with a profile (nodes at the changes' ends for an exact integration).
    changes : tuple of LocalChange
        The changes, applied in turn.
    plane : str
        "radial" or "tangential": which plane's second moment a flat changes.

    Returns
    -------
    BatModel
        The changed model (the same object when there is no change).
    """
    if not changes:
        return model
    if plane not in ("radial", "tangential"):
        raise ValueError(f"unknown bending plane {plane!r}")
    s = model.samples
    props = [np.array(v, dtype=float) for v in (s.props.ei, s.props.kga, s.props.rhoa,
                                                s.props.rhoi)]
    for change in changes:
        _one_change(model, props, change, plane)
    samples = replace(s, props=SectionProps(*props))
    phi, parts = parts_from_samples(model.node_x_m, samples, model.beam, model.rotary_inertia)
    return replace(model, samples=samples, phi=phi, parts=parts)
