"""Wood as the beam model sees it: Young's modulus along the grain, density, E/G."""

from __future__ import annotations

from dataclasses import dataclass, replace

from updating.model.units import LBF_IN3_TO_KG_M3, PSI_TO_PA

ISOTROPIC_E_OVER_G = 2.6
"""E/G = 2(1 + nu) for an isotropic solid with nu = 0.3 (the paper's assumption)."""


@dataclass(frozen=True)
class Material:
    """Beam material, SI.

    Attributes
    ----------
        E_pa: Young's modulus along the axis, Pa.
        rho_kg_m3: mass density, kg/m^3.
        e_over_g: E / G_LT (isotropic 2.6; wood 9-16).
        nu: Poisson's ratio used in the shear coefficient.
        shear_coefficient: "cowper" (default, the paper's era) or "hutchinson"
            (updating.model.sections).
    """

    E_pa: float
    rho_kg_m3: float
    e_over_g: float = ISOTROPIC_E_OVER_G
    nu: float = 0.3
    shear_coefficient: str = "cowper"

    @property
    def G_pa(self) -> float:
        """Return the shear modulus G = E / (E/G), Pa."""
        return self.E_pa / self.e_over_g

    def scaled(self, stiffness: float = 1.0, density: float = 1.0) -> Material:
        """Uniformly scaled material (moisture or temperature drift): E*stiffness, rho*density."""
        return replace(self, E_pa=self.E_pa * stiffness, rho_kg_m3=self.rho_kg_m3 * density)


def material_from_imperial(
    E_psi: float, weight_density_lbf_in3: float, e_over_g: float = ISOTROPIC_E_OVER_G
) -> Material:
    """Material from handbook units (psi, lbf/in^3 weight density)."""
    return Material(E_psi * PSI_TO_PA, weight_density_lbf_in3 * LBF_IN3_TO_KG_M3, e_over_g)


def paper_material() -> Material:
    """Return the paper's white birch: E = 1.8e6 psi, 0.02167 lbf/in^3, isotropic."""
    return material_from_imperial(1.8e6, 0.02167)
