"""A bat's calibrated reference: the model parameters that reproduce its baseline test.

Produced by diagnose (from the baseline test), stored in the registry, used by inspect as
the reference for MSSO and for the physical-change fit.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from updating.model.assembly import Attachment, BatModel, Beam, build_model
from updating.model.material import Material
from updating.model.profile import Profile
from updating.model.sections import Core
from updating.model.units import IN_TO_M


@dataclass(frozen=True)
class BatReference:
    """Calibrated model parameters, SI.

    Attributes
    ----------
        E_pa, rho_kg_m3, e_over_g, nu: the wood.
        beam: "euler" or "timoshenko"; rotary_inertia: include rhoI.
        sensor_mass_kg, sensor_x_m: accelerometer at the driving point.
        bungee_k_n_per_m: each of two bungees 1 in from either end (0: free-free).
        element_length_m: the mesh the parameters were calibrated on (nodes also at the test
            points); None: the default ~1 in grid.
        shear_coefficient: "cowper" or "hutchinson" (updating.model.sections).
        e_over_g_plane2, tap_angle_deg: the second bending plane's E/G and the tapping angle
            from the first plane, when diagnose resolved both planes (else None); the model
            built here is the first plane's.
        beam_theory_corrections: per-mode frequency corrections c_r measured against a 3D
            solid (f_3D = f_1D (1 + c_r)), one row per bending plane, when diagnose used them
            (else None). Carried for the record; inspect does not apply them yet.
    """

    E_pa: float
    rho_kg_m3: float
    e_over_g: float = 2.6
    nu: float = 0.3
    beam: Beam = "euler"
    rotary_inertia: bool = False
    sensor_mass_kg: float = 0.0
    sensor_x_m: float = 0.0
    bungee_k_n_per_m: float = 0.0
    element_length_m: float | None = None
    shear_coefficient: str = "cowper"
    e_over_g_plane2: float | None = None
    tap_angle_deg: float | None = None
    beam_theory_corrections: tuple[tuple[float, ...], ...] | None = None

    def material(self) -> Material:
        """Return the calibrated wood as a ``Material``."""
        return Material(self.E_pa, self.rho_kg_m3, self.e_over_g, self.nu,
                        self.shear_coefficient)

    def attachments(self, length_m: float) -> tuple[Attachment, ...]:
        """Return the accelerometer and the two bungees (1 in from either end) as attachments."""
        out = []
        if self.sensor_mass_kg:
            out.append(Attachment(self.sensor_x_m, mass_kg=self.sensor_mass_kg))
        if self.bungee_k_n_per_m:
            out += [Attachment(x, k_n_per_m=self.bungee_k_n_per_m)
                    for x in (IN_TO_M, length_m - IN_TO_M)]
        return tuple(out)

    def build(
        self, profile: Profile, stations_m=(), core: Core | None = None,
        n_elements: int | None = None, element_length_m: float | None = None,
    ) -> BatModel:
        """Build the reference FE model with nodes at ``stations_m`` (the test points).

        The mesh is the calibrated one unless ``n_elements`` or ``element_length_m`` says
        otherwise.
        """
        if n_elements is None and element_length_m is None:
            element_length_m = self.element_length_m
        return build_model(profile, self.material(), beam=self.beam,
                           rotary_inertia=self.rotary_inertia, n_elements=n_elements,
                           element_length_m=element_length_m, stations_m=np.asarray(stations_m),
                           core=core, attachments=self.attachments(profile.length_m))

    def to_dict(self) -> dict:
        """Return the reference as a JSON-able dict."""
        return asdict(self)

    @staticmethod
    def from_dict(d: dict) -> BatReference:
        """Read a reference back from ``to_dict``'s dict (unknown keys ignored)."""
        kw = {k: d[k] for k in BatReference.__dataclass_fields__ if k in d}
        if kw.get("beam_theory_corrections") is not None:
            kw["beam_theory_corrections"] = tuple(tuple(r) for r in kw["beam_theory_corrections"])
        return BatReference(**kw)
