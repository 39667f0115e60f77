"""The 3D solid check: mesh convergence, and the 1D beam against the solid for a uniform
cylinder, a smooth bat and the paper's stepped bat (tables in docs/model.md).

Wood: white ash, E_L = 1.74 Mpsi, 0.0217 lbf/in^3, E/G_LR = 11, E/G_LT = 15, planar grain
(the two bending planes differ), the other constants from the Wood Handbook
(updating.solid.elastic). For each bat and each plane: the RMS frequency error of the 1D
Timoshenko beam over the first six bending modes, nominal (the solid's E_L and E/G) and
after fitting E and E/G, with Cowper's and Hutchinson's shear coefficients, and the fitted
E and E/G against the solid's.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_solid.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from updating.model.profile import make_profile, paper_profile, read_profile_csv  # noqa: E402
from updating.model.units import IN_TO_M, LBF_IN3_TO_KG_M3, PSI_TO_PA  # noqa: E402
from updating.solid.compare import check_plane  # noqa: E402
from updating.solid.elastic import OrthotropicWood, isotropic  # noqa: E402
from updating.solid.mesh import bat_mesh  # noqa: E402
from updating.solid.modes import solid_modes  # noqa: E402

ASH = OrthotropicWood(1.74e6 * PSI_TO_PA, 0.0217 * LBF_IN3_TO_KG_M3, e_over_g_lr=11.0,
                      e_over_g_lt=15.0)
BATS = {
    "cylinder 34 x 2.5 in": make_profile(np.array([0.0, 34.0]) * IN_TO_M,
                                         np.array([2.5, 2.5]) * IN_TO_M),
    "smooth bat": read_profile_csv(ROOT / "data_samples/smooth_bat/profile.csv"),
    "paper's stepped bat": paper_profile(),
}


def convergence(profile) -> None:
    print("mesh convergence, smooth bat, ash, plane y: bending frequencies (Hz)")
    print(f"{'axial x section x ring':<24}{'DOF':>8}{'s':>7}  f1..f6")
    ref = None
    rows = []
    for na, ns, nr in ((20, 2, 1), (40, 2, 1), (80, 2, 1), (40, 4, 2), (80, 4, 2)):
        t0 = time.perf_counter()
        m = solid_modes(bat_mesh(profile, na, ns, nr), ASH, 26)
        dt = time.perf_counter() - t0
        f = m.bending_hz("y")[:6]
        rows.append((na, ns, nr, m.n_dof, dt, f))
        ref = f
    for na, ns, nr, n_dof, dt, f in rows:
        dev = 100 * np.max(np.abs(f / ref - 1))
        print(f"{f'{na} x {ns}x{ns}+ring {nr}':<24}{n_dof:>8}{dt:>7.1f}  "
              + " ".join(f"{v:8.2f}" for v in f) + f"   max dev from finest {dev:.3f} %",
              flush=True)


def comparison() -> None:
    print("\n1D Timoshenko beam against the 3D solid, first six bending modes per plane")
    print(f"{'bat':<22}{'plane':>6}{'k':>12}{'nominal RMS %':>15}{'fitted RMS %':>14}"
          f"{'E fit/true':>12}{'E/G fit/true':>14}")
    cases = [("steel cylinder", BATS["cylinder 34 x 2.5 in"], isotropic(200e9, 7850, 0.3),
              "cylindrical")] + [(n, p, ASH, "planar") for n, p in BATS.items()]
    for name, profile, wood, orient in cases:
        t0 = time.perf_counter()
        modes = solid_modes(bat_mesh(profile, 80, 2, 1), wood, 26, orient)
        if orient == "cylindrical":
            modes = modes.one_plane()
        planes = ("y",) if orient == "cylindrical" else ("y", "z")
        nu = 0.3
        for plane in planes:
            for k in ("cowper", "hutchinson"):
                c = check_plane(profile, modes, wood, plane, 6, nu, k)
                print(f"{name:<22}{plane:>6}{k:>12}{c.nominal_rms_pct:>15.3f}"
                      f"{c.calibrated_rms_pct:>14.3f}{c.E_pa / wood.E_L_pa:>12.4f}"
                      f"{c.e_over_g / c.e_over_g_true:>14.3f}", flush=True)
        if orient == "planar":
            fy, fz = modes.bending_hz("y")[:6], modes.bending_hz("z")[:6]
            print(f"{'':<22}  split of the pairs, %: "
                  + " ".join(f"{v:.2f}" for v in 100 * (fy / fz - 1))
                  + f"   (3D solve {time.perf_counter() - t0:.0f} s)", flush=True)


def main() -> None:
    convergence(BATS["smooth bat"])
    comparison()


if __name__ == "__main__":
    main()
