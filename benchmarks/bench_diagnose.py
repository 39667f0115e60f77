"""Accuracy and time of `diagnose` over random bats on the virtual rig (no FRF stage).

Each bat: a caliper-noisy pro profile (2 % diameter scatter), white-ash handbook values off
by E +-15 % and density +-8 %, E/G 10-18, a 2-6 g accelerometer at the driving point 1 in
from the barrel end, bungees 50-800 N/m, Timoshenko truth with rotary inertia on a 0.5 in
mesh; the modes below 3 kHz with 0.05 % frequency noise and a given shape noise. Then the
same for Euler-Bernoulli bats (no shear in the data): how often is shear claimed?

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_diagnose.py [n_bats]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from updating.diagnose.run import diagnose  # noqa: E402
from updating.model.assembly import build_model  # noqa: E402
from updating.model.lab_input import BatMeta  # noqa: E402
from updating.model.mass_properties import mass_properties  # noqa: E402
from updating.model.material import Material, material_from_imperial  # noqa: E402
from updating.model.profile import make_profile  # noqa: E402
from updating.model.units import IN_TO_M  # noqa: E402
from updating.simulate.virtual_bat import VirtualBat, simulate_modes  # noqa: E402

X_IN = np.array([0, 0.5, 1.0, 2, 8, 14, 20, 24, 28, 33.5, 34])
D_IN = np.array([1.6, 1.6, 1.0, 0.95, 0.97, 1.2, 1.9, 2.4, 2.55, 2.55, 2.45])
POINTS = np.arange(1, 34, 2) * IN_TO_M
ASH = material_from_imperial(1.74e6, 0.0217)


def random_bat(rng, beam: str):
    profile = make_profile(X_IN * IN_TO_M,
                           D_IN * (1 + 0.02 * rng.standard_normal(D_IN.size)) * IN_TO_M)
    e_over_g = rng.uniform(10, 18) if beam == "timoshenko" else 2.6
    wood = Material(ASH.E_pa * rng.uniform(0.85, 1.15), ASH.rho_kg_m3 * rng.uniform(0.92, 1.08),
                    e_over_g)
    bat = VirtualBat(profile, wood, POINTS, sensor_mass_kg=rng.uniform(2e-3, 6e-3),
                     bungee_k_n_per_m=rng.uniform(50, 800), beam=beam)
    weight = mass_properties(build_model(profile, wood)).mass_kg
    return bat, BatMeta("B", "white ash", ASH, weight, POINTS)


def run(n: int, shape_noise: float, beam: str, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    rows = []
    for i in range(n):
        bat, meta = random_bat(rng, beam)
        meas = simulate_modes(bat, n_modes=8, freq_noise=5e-4, shape_noise=shape_noise,
                              seed=seed * 1000 + i)
        meas = meas.select(np.flatnonzero(meas.freq_hz < 3000.0))
        t0 = time.perf_counter()
        res = diagnose(bat.profile, meta, meas)
        dt = time.perf_counter() - t0
        ref = res.reference
        rows.append((abs(ref.E_pa / bat.material.E_pa - 1) * 100,
                     abs(ref.e_over_g / bat.material.e_over_g - 1) * 100,
                     abs(ref.sensor_mass_kg - bat.sensor_mass_kg) * 1e3,
                     res.nominal.rms_pct, res.extended.rms_pct,
                     "shear_deformation" in [c.name for c in res.causes], dt))
    return {"rows": np.array(rows, dtype=float)}


def stats(v: np.ndarray) -> str:
    return f"{np.median(v):7.3f} {np.percentile(v, 95):7.3f} {v.max():7.3f}"


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 30
    print(f"diagnose over {n} random bats per row (median / 95th percentile / max)")
    print(f"{'truth, shape noise':<24}{'|E err| %':>24}{'|E/G err| %':>24}"
          f"{'|sensor err| g':>24}{'RMS nominal %':>24}{'RMS calibrated %':>24}"
          f"  shear named  s/bat")
    for beam, noise, seed in (("timoshenko", 0.005, 1), ("timoshenko", 0.01, 2),
                              ("euler", 0.005, 3)):
        r = run(n, noise, beam, seed)["rows"]
        eg = stats(r[:, 1]) if beam == "timoshenko" else f"{'(2.6, not fitted)':>23}"
        print(f"{beam + ', ' + format(noise * 100, '.1f') + ' %':<24}{stats(r[:, 0]):>24}"
              f"{eg:>24}{stats(r[:, 2]):>24}{stats(r[:, 3]):>24}{stats(r[:, 4]):>24}"
              f"  {int(r[:, 5].sum()):3d}/{n:<3d}     {r[:, 6].mean():5.1f}", flush=True)
    print("tolerances: E 3 %, E/G 25 %, sensor 1 g, calibrated RMS 0.3 %")


if __name__ == "__main__":
    main()
