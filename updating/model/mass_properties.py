"""Mass properties of the bat model, from the same section quadrature as the mass matrix.

m = int rhoA dx,  x_cg = int rhoA x dx / m,  I_knob = int (rhoA x^2 + rhoI) dx,
I_cg = I_knob - m x_cg^2   (about a transverse axis; point masses added).

The free rigid body's mass line (``rigid_mass_line``): the flexibility between a force at
x_d and the acceleration at x of a free body, G(x, x_d) = 1/m + (x - x_cg)(x_d - x_cg)/I_cg
(Ewins, Modal Testing, 2000, sec. 4.3: the lower residual of a free body's accelerance).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from updating.model.assembly import BatModel


@dataclass(frozen=True)
class MassProperties:
    """A model's mass, centre of mass and transverse moments of inertia.

    Attributes
    ----------
    mass_kg : float
        Mass, kg.
    cg_m : float
        Centre of mass from the knob end, m.
    i_knob_kg_m2, i_cg_kg_m2 : float
        Moment of inertia about the knob end and about the centre of mass, kg m^2.
    """

    mass_kg: float
    cg_m: float
    i_knob_kg_m2: float
    i_cg_kg_m2: float


def mass_properties(model: BatModel, with_attachments: bool = False,
                    density_factor: Callable[[np.ndarray], np.ndarray] | None = None,
                    ) -> MassProperties:
    """Mass, centre of mass and transverse moments of inertia (rotary inertia always counted).

    ``density_factor(x_m)`` multiplies the model's density along the bat (a billet's
    gradient), at the quadrature samples; None: the model's own.
    """
    s = model.samples
    w, x = s.weight_m, s.x_m
    if density_factor is not None:
        w = w * density_factor(x)
    m = float(np.sum(w * s.props.rhoa))
    mx = float(np.sum(w * s.props.rhoa * x))
    i0 = float(np.sum(w * (s.props.rhoa * x**2 + s.props.rhoi)))
    if with_attachments:
        for a in model.attachments:
            m, mx, i0 = m + a.mass_kg, mx + a.mass_kg * a.x_m, i0 + a.mass_kg * a.x_m**2
    cg = mx / m
    return MassProperties(m, cg, i0, i0 - m * cg**2)


def solid_mass_properties(x_m: np.ndarray, diameter_m: np.ndarray, mass_kg: float,
                          n: int = 2001) -> MassProperties:
    """Mass properties of a profile's solid of revolution at uniform density.

    ``n`` equal slices, each's mass in proportion to its area of the profile interpolated
    linearly; the sections' own rotary inertia is left out, so this needs no model (within
    0.3 % of the model's pitch inertia on a bat, ``tests/test_ema_mass_line.py``).

    Parameters
    ----------
    x_m, diameter_m : ndarray
        The profile's stations from the knob end and the diameters there, m.
    mass_kg : float
        The solid's mass, kg.
    n : int
        Slices.
    """
    x = np.linspace(x_m[0], x_m[-1], n)
    area = np.pi / 4 * np.interp(x, x_m, diameter_m) ** 2
    dm = mass_kg * area / area.sum()
    cg = float(dm @ x) / mass_kg
    i_cg = float(dm @ (x - cg) ** 2)
    return MassProperties(float(mass_kg), cg, i_cg + mass_kg * cg**2, i_cg)


def with_point_mass(mp: MassProperties, mass_kg: float, x_m: float) -> MassProperties:
    """Return ``mp`` with a point mass ``mass_kg`` at ``x_m`` (an accelerometer), SI."""
    m = mp.mass_kg + mass_kg
    cg = (mp.mass_kg * mp.cg_m + mass_kg * x_m) / m
    i_knob = mp.i_knob_kg_m2 + mass_kg * x_m**2
    i_cg = mp.i_cg_kg_m2 + mp.mass_kg * (mp.cg_m - cg) ** 2 + mass_kg * (x_m - cg) ** 2
    return MassProperties(m, cg, i_knob, i_cg)


def rigid_mass_line(mp: MassProperties, x_m, x_drive_m: float):
    """Return the free rigid body's mass line G(x, x_d) = 1/m + (x - x_cg)(x_d - x_cg)/I_cg.

    Parameters
    ----------
    mp : MassProperties
        The body's mass properties (its accelerometer included, ``with_point_mass``).
    x_m : float or ndarray
        Where the response is read, m from the knob end.
    x_drive_m : float
        Where the force acts, m from the knob end.

    Returns
    -------
    float or ndarray
        The flexibility, 1/kg (acceleration per force).
    """
    return 1.0 / mp.mass_kg + (np.asarray(x_m) - mp.cg_m) * (x_drive_m - mp.cg_m) / mp.i_cg_kg_m2


@dataclass(frozen=True)
class CoreFromMass:
    """An axial core inferred from the change of mass properties alone."""

    length_m: float  # filled length (depth - plug)
    start_m: float  # start of the filled part from the knob end
    diameter_m: float
    fill_density_ratio: float


def core_from_mass_change(
    before: MassProperties, after: MassProperties, bat_length_m: float, plug_m: float,
    rho_kg_m3: float,
) -> CoreFromMass:
    """Recover a core (filled length, diameter, fill ratio) from mass properties.

    A filled core of length l ending ``plug_m`` from the barrel end, centred at
    x_c = L - plug - l/2, with area A_c = pi d^2 / 4 and fill ratio r changes

        dm = rho (r - 1) A_c l,   d(m x_cg) = dm x_c,
        dI_knob = dm (x_c^2 + l^2/12) + rho (r - 1) (pi d^4 / 64) l,

    so the weight and centre-of-mass shift give l and d^2 (r - 1); the section's own rotary
    inertia in dI_knob separates d from r (d^2 = 16 dI_rot / dm). On a scale and a
    pendulum only the first two are measurable (the last term is ~1e-4 of I_knob), so in
    practice the weight and balance point give the depth and d^2 (r - 1).
    """
    dm = after.mass_kg - before.mass_kg
    if abs(dm) < 1e-12 * before.mass_kg:
        raise ValueError("no mass change: a density-neutral fill is invisible to the scale")
    x_c = (after.mass_kg * after.cg_m - before.mass_kg * before.cg_m) / dm
    length = 2.0 * (bat_length_m - plug_m - x_c)
    di_rot = after.i_knob_kg_m2 - before.i_knob_kg_m2 - dm * (x_c**2 + length**2 / 12)
    d2 = 16.0 * di_rot / dm
    if length <= 0 or d2 <= 0:
        raise ValueError("mass change is not that of an axial core at the barrel end")
    r = 1.0 + dm / (rho_kg_m3 * np.pi / 4 * d2 * length)
    return CoreFromMass(length, x_c - length / 2, float(np.sqrt(d2)), float(r))
