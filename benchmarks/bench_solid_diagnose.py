"""Diagnose on 3D-simulated test data: both bending planes excited (docs/diagnose.md).

The truth is the 3D solid (updating.solid) of the smooth bat and of the paper's stepped bat
in data_samples: the handbook wood of meta.json,
E_L 5 % above the handbook's, E/G_LR = 11, E/G_LT = 15, planar grain, a 3 g accelerometer on
the axis at the driving point (33 in), free-free; tapped at 30 degrees from the radial plane,
so each bending mode appears as a pair (cos^2 / sin^2 of the amplitude). Six modes per
plane, 0.05 % frequency and 0.5 % shape noise. Diagnose runs without and with the solid's
per-mode corrections (`--solid`: a second 3D model built from the first pass's fitted E and
E/G, updating.diagnose.solid). For each: the errors of E, E/G (both planes), tap angle and
sensor mass, the RMS error before and after, the named causes with their gains (which add up
along the selection path to the RMS drop) and the warnings.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_solid_diagnose.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from updating.diagnose.run import diagnose  # noqa: E402
from updating.diagnose.solid import diagnose_with_solid  # noqa: E402
from updating.model.assembly import build_model  # noqa: E402
from updating.model.lab_input import read_meta  # noqa: E402
from updating.model.mass_properties import mass_properties  # noqa: E402
from updating.model.material import Material  # noqa: E402
from updating.model.profile import read_profile_csv  # noqa: E402
from updating.solid.elastic import OrthotropicWood  # noqa: E402
from updating.solid.measured import tap_test_modes  # noqa: E402
from updating.solid.mesh import bat_mesh  # noqa: E402
from updating.solid.modes import solid_modes  # noqa: E402

SENSOR_KG = 3e-3
THETA_DEG = 30.0


def main() -> None:
    for name in ("smooth_bat", "paper_bat"):
        print(f"\n=== {name}")
        run(ROOT / "data_samples" / name)


def run(bat: Path) -> None:
    profile = read_profile_csv(bat / "profile.csv")
    meta = read_meta(bat / "meta.json")
    hb = meta.material
    truth = OrthotropicWood(hb.E_pa * 1.05, hb.rho_kg_m3, e_over_g_lr=11.0, e_over_g_lt=15.0)
    weight = mass_properties(build_model(profile, Material(truth.E_L_pa, truth.rho_kg_m3)))
    meta = type(meta)(meta.serial, meta.species, hb, weight.mass_kg, meta.points_m)
    points = np.asarray(meta.points_m)
    sensor_x = float(points[-1])
    t0 = time.perf_counter()
    modes = solid_modes(bat_mesh(profile, 40, 2, 1), truth, 30, "planar",
                        point_masses=((sensor_x, SENSOR_KG),))
    meas = tap_test_modes(modes, points, sensor_x, THETA_DEG, 6, seed=7)
    print(f"3D truth: {meas.freq_hz.size} modes, {time.perf_counter() - t0:.0f} s")
    for label in ("1D family only", "with --solid"):
        t0 = time.perf_counter()
        if label == "with --solid":
            res, corr = diagnose_with_solid(profile, meta, meas)
            print("corrections per plane, %: " + "; ".join(
                " ".join(f"{100 * c:+.3f}" for c in row) for row in corr))
        else:
            res = diagnose(profile, meta, meas)
        out = res.to_json_dict()
        ref = res.reference
        print(f"\n{label}: {time.perf_counter() - t0:.0f} s, {res.n_split} split pairs")
        print(f"  E error {100 * (ref.E_pa / truth.E_L_pa - 1):+.2f} %, "
              f"E/G plane 1 {ref.e_over_g:.2f} (11: {100 * (ref.e_over_g / 11 - 1):+.1f} %), "
              f"plane 2 {ref.e_over_g_plane2 or float('nan'):.2f} "
              f"(15: {100 * ((ref.e_over_g_plane2 or np.nan) / 15 - 1):+.1f} %), "
              f"tap angle {ref.tap_angle_deg or float('nan'):.1f} deg, "
              f"sensor {1e3 * ref.sensor_mass_kg:.2f} g (true 3)")
        rms = out["rms_error_pct"]
        path = [s.gain_pct for s in res.steps if s.role != "rejected"]
        print(f"  RMS nominal {rms['nominal']:.3f} % -> calibrated {rms['extended']:.3f} %; "
              f"gains along the path sum to {sum(path):.3f} pp "
              f"(drop {rms['nominal'] - rms['extended']:.3f} pp)")
        for cause in out["causes"]:
            print(f"  cause {cause['name']:<18} gain {cause['gain_pct']:.3f} pp")
        for w in out["warnings"]:
            print(f"  warning: {w}")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
