"""Section properties of a solid or axially cored (drilled and filled) circular bat section.

Area A = pi/4 (D^2 - d^2), second moment I = pi/64 (D^4 - d^4) for the wood annulus; a fill of
density ratio r and modulus ratio s adds r rho pi/4 d^2 and s E pi/64 d^4. Shear coefficient
of a circular tube (Cowper 1966, J. Appl. Mech. 33:335), m = d/D:

    k = 6 (1 + nu) (1 + m^2)^2 / ((7 + 6 nu) (1 + m^2)^2 + (20 + 12 nu) m^2)

(solid section: m = 0, k = 6(1+nu)/(7+6nu)), or Hutchinson's (2001, J. Appl. Mech. 68:87;
identical to Stephen & Levinson's), derived for long-wavelength flexural vibration:

    k = 6 (1 + m^2)^2 (1 + nu)^2 / (7 + 34 m^2 + 7 m^4 + nu (12 + 48 m^2 + 12 m^4)
                                    + nu^2 (4 + 16 m^2 + 4 m^4))

(solid: k = 6 (1+nu)^2 / (7 + 12 nu + 4 nu^2)). Against a 3D solid Hutchinson's value matches
the bending modes of a cylinder better (docs/model.md). Because transverse shear stress peaks
at the centre, a cored section loses more shear stiffness kGA than area.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.model.material import Material


@dataclass(frozen=True)
class Core:
    """An axial core drilled from the barrel end and filled (an alteration).

    Attributes
    ----------
        diameter_m: core diameter, m.
        depth_m: drilled depth from the barrel end, m.
        fill_density_ratio: fill density / wood density (cork ~0.2-0.4, heavy fill 1.5-2.2).
        fill_modulus_ratio: fill modulus / wood modulus (cork ~0).
        plug_m: length re-plugged with wood at the barrel end, m.
        empty_m: length of the hole left empty right behind the plug, m (a partial fill:
            the fill sits at the bottom of the hole); 0 for a hole filled to the plug.
    """

    diameter_m: float
    depth_m: float
    fill_density_ratio: float
    fill_modulus_ratio: float = 0.0
    plug_m: float = 0.0254
    empty_m: float = 0.0

    def interval_m(self, length_m: float) -> tuple[float, float]:
        """(start, end) of the hole behind the plug along the bat, m from the knob end."""
        return length_m - self.depth_m, length_m - self.plug_m

    @property
    def mean_fill_density_ratio(self) -> float:
        """The fill ratio averaged over the hole: r (1 - empty / hole length)."""
        return self.fill_density_ratio * (1.0 - self.empty_m / (self.depth_m - self.plug_m))


def cowper_k(m: np.ndarray, nu: float) -> np.ndarray:
    """Cowper's shear coefficient of a circular tube with inner/outer diameter ratio m."""
    m2 = np.asarray(m, dtype=float) ** 2
    return 6 * (1 + nu) * (1 + m2) ** 2 / ((7 + 6 * nu) * (1 + m2) ** 2 + (20 + 12 * nu) * m2)


def hutchinson_k(m: np.ndarray, nu: float) -> np.ndarray:
    """Hutchinson's shear coefficient of a circular tube with inner/outer diameter ratio m."""
    m2 = np.asarray(m, dtype=float) ** 2
    m4 = m2 * m2
    den = (7 + 34 * m2 + 7 * m4 + nu * (12 + 48 * m2 + 12 * m4)
           + nu**2 * (4 + 16 * m2 + 4 * m4))
    return 6 * (1 + m2) ** 2 * (1 + nu) ** 2 / den


SHEAR_COEFFICIENTS = {"cowper": cowper_k, "hutchinson": hutchinson_k}


def shear_k(m: np.ndarray, nu: float, formula: str = "cowper") -> np.ndarray:
    """Shear coefficient of a circular tube by the named formula (cowper or hutchinson)."""
    try:
        return SHEAR_COEFFICIENTS[formula](m, nu)
    except KeyError:
        raise ValueError(f"unknown shear coefficient {formula!r} "
                         f"({' or '.join(SHEAR_COEFFICIENTS)})") from None


@dataclass(frozen=True)
class SectionProps:
    """Beam section properties at sample points (arrays of one shape)."""

    ei: np.ndarray  # bending stiffness E I, N m^2
    kga: np.ndarray  # shear stiffness k G A, N
    rhoa: np.ndarray  # mass per length rho A, kg/m
    rhoi: np.ndarray  # rotary inertia per length rho I, kg m


def section_props(
    D_m: np.ndarray, material: Material, core_d_m: np.ndarray | float = 0.0,
    fill_density_ratio: np.ndarray | float = 0.0, fill_modulus_ratio: np.ndarray | float = 0.0,
) -> SectionProps:
    """Compute the properties of circular sections of outer diameter D with a filled core.

    The core has diameter d; fill ratios are given per section or one for all.
    """
    D = np.asarray(D_m, dtype=float)
    d = np.broadcast_to(np.asarray(core_d_m, dtype=float), D.shape)
    if np.any(d >= D):
        raise ValueError("core diameter must be smaller than the outer diameter")
    a_wood = np.pi / 4 * (D**2 - d**2)
    a_fill = np.pi / 4 * d**2
    i_wood = np.pi / 64 * (D**4 - d**4)
    i_fill = np.pi / 64 * d**4
    E, rho, G, nu = material.E_pa, material.rho_kg_m3, material.G_pa, material.nu
    s, r = fill_modulus_ratio, fill_density_ratio
    k = material.shear_coefficient
    return SectionProps(
        ei=E * (i_wood + s * i_fill),
        kga=G * (shear_k(d / D, nu, k) * a_wood + s * shear_k(0.0, nu, k) * a_fill),
        rhoa=rho * (a_wood + r * a_fill),
        rhoi=rho * (i_wood + r * i_fill),
    )
