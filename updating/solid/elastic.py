"""Wood's orthotropic elastic constants and their stiffness matrix (Voigt notation).

Material axes: L along the grain (the bat's axis), R radial, T tangential to the growth rings.
Compliance (Voigt, engineering shear strains, order 11 22 33 23 13 12 with 1 = L, 2 = R,
3 = T; nu_ij = -eps_j / eps_i under stress i; minor ratios from symmetry nu_ji = nu_ij E_j/E_i):

    S = [[1/E_L, -nu_LR/E_L, -nu_LT/E_L], [., 1/E_R, -nu_RT/E_R], [., ., 1/E_T]],
    S44 = 1/G_RT,  S55 = 1/G_LT,  S66 = 1/G_LR;    D = S^-1.

Default ratios (USDA Wood Handbook, FPL-GTR-190, tables 5-1 and 5-2, white ash, 12 %
moisture): E_R/E_L = 0.125, E_T/E_L = 0.080, nu_LR = 0.371, nu_LT = 0.440, nu_RT = 0.684;
the handbook has no G_RT for ash, G_RT/E_L = 0.02 is typical of hardwoods. The shear moduli
along the grain are given as E_L/G_LR and E_L/G_LT (handbook ash 11.2 and 11.5; batlab's
test bats use 9-16).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class OrthotropicWood:
    """Orthotropic wood, SI; E_L is the beam model's E."""

    E_L_pa: float
    rho_kg_m3: float
    e_over_g_lr: float = 11.2
    e_over_g_lt: float = 11.5
    er_over_el: float = 0.125
    et_over_el: float = 0.080
    grt_over_el: float = 0.02
    nu_lr: float = 0.371
    nu_lt: float = 0.440
    nu_rt: float = 0.684

    def compliance(self) -> np.ndarray:
        """6x6 compliance in material axes (L, R, T)."""
        E1, E2, E3 = self.E_L_pa, self.E_L_pa * self.er_over_el, self.E_L_pa * self.et_over_el
        S = np.zeros((6, 6))
        S[0, 0], S[1, 1], S[2, 2] = 1 / E1, 1 / E2, 1 / E3
        S[0, 1] = S[1, 0] = -self.nu_lr / E1
        S[0, 2] = S[2, 0] = -self.nu_lt / E1
        S[1, 2] = S[2, 1] = -self.nu_rt / E2
        S[3, 3] = 1 / (self.grt_over_el * E1)
        S[4, 4] = self.e_over_g_lt / E1
        S[5, 5] = self.e_over_g_lr / E1
        return S

    def stiffness(self) -> np.ndarray:
        """6x6 stiffness D = S^-1 in material axes; raises if not positive definite."""
        D = np.linalg.inv(self.compliance())
        if np.min(np.linalg.eigvalsh(D)) <= 0:
            raise ValueError("orthotropic constants are not positive definite")
        return D


def isotropic(E_pa: float, rho_kg_m3: float, nu: float) -> OrthotropicWood:
    """Return an isotropic material in the same form (E/G = 2 (1 + nu))."""
    r = 2 * (1 + nu)
    return OrthotropicWood(E_pa, rho_kg_m3, r, r, 1.0, 1.0, 1 / r, nu, nu, nu)


VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))


def rotate_voigt(D: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Rotate a stiffness D (6x6, material axes) into global axes.

    R (..., 3, 3) has columns the material axes in global components:
    C'_ijkl = R_ia R_jb R_kc R_ld C_abcd.
    """
    C = np.zeros((3, 3, 3, 3))
    for I, (i, j) in enumerate(VOIGT):
        for J, (k, l) in enumerate(VOIGT):
            for a, b in {(i, j), (j, i)}:
                for c, d in {(k, l), (l, k)}:
                    C[a, b, c, d] = D[I, J]
    T = np.stack([np.stack([R[..., i, :, None] * R[..., j, None, :] for j in range(3)], -3)
                  for i in range(3)], -4)  # (..., 3, 3, 3, 3): T_ijab = R_ia R_jb
    Cg = np.einsum("...ijab,abcd,...klcd->...ijkl", T, C, T, optimize=True)
    out = np.empty(R.shape[:-2] + (6, 6))
    for I, (i, j) in enumerate(VOIGT):
        for J, (k, l) in enumerate(VOIGT):
            out[..., I, J] = Cg[..., i, j, k, l]
    return out
