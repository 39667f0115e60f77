"""What the 1D beam misses: a bat's 3D solid modes against the 1D Timoshenko model.

For each bending plane the 1D model (Timoshenko, rotary inertia, 0.25 in elements, the chosen
shear coefficient) is compared with the solid's bending frequencies twice:
- nominal: with the solid's own E_L and E_L/G of that plane (what beam theory predicts);
- calibrated: E and E/G fitted to the solid's frequencies (least squares on
  e_r = f_1D,r / f_3D,r - 1): the residual RMS is what no E, E/G can absorb, the fitted
  values show the bias that absorbing it would cause.
The nominal errors give per-mode corrections c_r = f_3D,r / f_1D,r - 1 that a 1D reference
can carry (updating.diagnose's `beam_theory` extension multiplies the model's frequencies by
1 + c_r); taken against the nominal beam, a 1D model carrying them estimates the solid's own
E and E/G.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize

from updating.model.assembly import build_model
from updating.model.material import Material
from updating.model.modes import model_modes
from updating.model.profile import Profile
from updating.model.units import IN_TO_M
from updating.solid.elastic import OrthotropicWood
from updating.solid.mesh import bat_mesh
from updating.solid.modes import SolidModes, solid_modes

FINE_1D_M = 0.25 * IN_TO_M


def beam_hz(profile: Profile, material: Material, n_modes: int,
            element_length_m: float | None = FINE_1D_M, stations_m=()) -> np.ndarray:
    """Compute the lowest n_modes elastic frequencies of the free-free 1D Timoshenko beam.

    0.25 in elements unless a mesh is given (None is the reference's ~1 in grid).
    """
    model = build_model(profile, material, beam="timoshenko", rotary_inertia=True,
                        element_length_m=element_length_m, stations_m=stations_m)
    return model_modes(model, n_modes + 2).elastic().freq_hz[:n_modes]


@dataclass(frozen=True)
class PlaneCheck:
    """One bending plane: 3D frequencies, the nominal and calibrated 1D ones.

    E_pa / e_over_g: the calibrated 1D values (the solid has E_L and e_over_g_true).
    """

    plane: str
    solid_hz: np.ndarray
    nominal_hz: np.ndarray
    calibrated_hz: np.ndarray
    e_over_g_true: float
    E_pa: float
    e_over_g: float

    @property
    def nominal_rms_pct(self) -> float:
        """Return the RMS relative error of the nominal 1D frequencies against the 3D ones, %."""
        return float(100 * np.sqrt(np.mean((self.nominal_hz / self.solid_hz - 1) ** 2)))

    @property
    def calibrated_rms_pct(self) -> float:
        """Return the RMS relative error of the calibrated 1D frequencies against the 3D ones, %."""
        return float(100 * np.sqrt(np.mean((self.calibrated_hz / self.solid_hz - 1) ** 2)))

    @property
    def corrections(self) -> np.ndarray:
        """Return c_r = f_3D / f_1D(nominal) - 1 against the beam with the solid's own E_L and E/G.

        So a 1D model carrying them and fitted to a test estimates the physical E and E/G (against
        the calibrated beam it would estimate the beam's biased ones).
        """
        return self.solid_hz / self.nominal_hz - 1


def calibrate(profile: Profile, target_hz: np.ndarray, start: Material) -> Material:
    """E and E/G of the 1D beam fitted to target frequencies (relative least squares)."""
    n = target_hz.size

    def res(x):
        m = Material(np.exp(x[0]), start.rho_kg_m3, np.exp(x[1]), start.nu,
                     start.shear_coefficient)
        return beam_hz(profile, m, n) / target_hz - 1

    x0 = np.log([start.E_pa, start.e_over_g])
    out = scipy.optimize.least_squares(res, x0, bounds=(np.log([1e7, 1.0]), np.log([1e12, 100.0])),
                                       x_scale=1.0, diff_step=1e-6, xtol=1e-12, ftol=1e-12)
    return Material(float(np.exp(out.x[0])), start.rho_kg_m3, float(np.exp(out.x[1])), start.nu,
                    start.shear_coefficient)


def check_plane(profile: Profile, modes: SolidModes, wood: OrthotropicWood, plane: str,
                n_modes: int, nu: float, shear_coefficient: str,
                mesh: tuple[float | None, tuple] = (FINE_1D_M, ())) -> PlaneCheck:
    """Compare the first n_modes bending modes of one plane, 3D against 1D.

    ``mesh`` (element length, stations) is the 1D nominal beam's (the calibration always uses
    the fine mesh).
    """
    f3 = modes.bending_hz(plane)[:n_modes]
    if f3.size < n_modes:
        raise ValueError(f"the solid gave only {f3.size} bending modes in plane {plane}; "
                         "ask for more modes")
    eg = wood.e_over_g_lr if plane == "y" else wood.e_over_g_lt
    nominal = Material(wood.E_L_pa, wood.rho_kg_m3, eg, nu, shear_coefficient)
    cal = calibrate(profile, f3, nominal)
    return PlaneCheck(plane, f3, beam_hz(profile, nominal, n_modes, *mesh),
                      beam_hz(profile, cal, n_modes), eg, cal.E_pa, cal.e_over_g)


def solid_check(profile: Profile, wood: OrthotropicWood, n_modes: int = 6,
                n_axial: int = 40, n_section: int = 2, n_ring: int = 1,
                orientation: str = "planar", nu: float = 0.3,
                shear_coefficient: str = "hutchinson", progress: bool = False,
                beam_mesh: tuple[float | None, tuple] = (FINE_1D_M, ()),
                ) -> tuple[PlaneCheck, ...]:
    """Solve the solid and compare each bending plane with the 1D beam."""
    mesh = bat_mesh(profile, n_axial, n_section, n_ring)
    modes = solid_modes(mesh, wood, 3 * n_modes + 8, orientation, progress)
    planes = ("y", "z") if orientation == "planar" else ("y",)
    if orientation != "planar":  # one plane: the pairs are degenerate
        modes = modes.one_plane()
    return tuple(check_plane(profile, modes, wood, p, n_modes, nu, shear_coefficient,
                             beam_mesh) for p in planes)


def beam_corrections(profile: Profile, wood: OrthotropicWood, n_modes: int = 8,
                     n_axial: int = 40, n_section: int = 2, n_ring: int = 1, nu: float = 0.3,
                     shear_coefficient: str = "cowper", progress: bool = False,
                     mesh: tuple[float | None, tuple] = (FINE_1D_M, ())) -> np.ndarray:
    """Compute per-mode corrections (2, n_modes) for a 1D reference, a row per bending plane.

    Rows y: the L-R plane, z: L-T. c = f_3D / f_1D(nominal) - 1 (planar grain), the 1D beam on
    ``mesh`` (element length or None for the ~1 in grid, stations): the reference's own mesh,
    so that its discretisation error is corrected too.
    """
    checks = solid_check(profile, wood, n_modes, n_axial, n_section, n_ring, "planar", nu,
                         shear_coefficient, progress, mesh)
    return np.array([c.corrections for c in checks])
