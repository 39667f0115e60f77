"""Diagnose with the 3D solid check (`batlab diagnose --solid`): what the 1D beam misses.

Two passes: (1) diagnose with the 1D model family; (2) build the bat's 3D solid
(updating.solid) with the fitted E, density and E/G of each bending plane (Wood Handbook
ratios for the rest), measure per-mode, per-plane corrections c_r = f_3D / f_1D - 1 against
the 1D beam with the same E and E/G on the first pass's mesh, and diagnose again with
'beam_theory' (f (1 + c_r)) in the model family. Its measured gain is what the beam theory
missed for this bat.
"""

from __future__ import annotations

import sys

import numpy as np

from updating.correlate.measured import MeasuredModes
from updating.diagnose.run import Diagnosis, diagnose
from updating.model.lab_input import BatMeta
from updating.model.profile import Profile
from updating.solid.compare import beam_corrections
from updating.solid.elastic import OrthotropicWood


def diagnose_with_solid(
    profile: Profile, meta: BatMeta, measured: MeasuredModes, suspension_hz=None,
    progress: bool = False, n_axial: int = 40, **kwargs,
) -> tuple[Diagnosis, np.ndarray]:
    """(diagnosis with 'beam_theory' tried, the corrections (2, k))."""
    first = diagnose(profile, meta, measured, suspension_hz, **kwargs)
    ref = first.reference
    wood = OrthotropicWood(ref.E_pa, ref.rho_kg_m3, e_over_g_lr=max(ref.e_over_g, 3.0),
                           e_over_g_lt=max(ref.e_over_g_plane2 or ref.e_over_g, 3.0))
    if progress:
        print(f"diagnose --solid: 3D solid with E/G {wood.e_over_g_lr:.1f} and "
              f"{wood.e_over_g_lt:.1f} in the two planes ...", file=sys.stderr)
    n = int(first.model_index.max()) + 2
    # the 1D beam on the reference's own mesh (diagnose.model.build), so the corrections
    # carry its discretisation error too
    fine = ref.element_length_m is not None
    mesh = (ref.element_length_m, tuple(measured.x_m) if fine else ())
    corr = beam_corrections(profile, wood, n_modes=n, n_axial=n_axial,
                            nu=meta.material.nu, progress=progress, mesh=mesh)
    return diagnose(profile, meta, measured, suspension_hz, solid_corrections=corr,
                    **kwargs), corr
