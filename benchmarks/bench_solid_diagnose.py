"""Diagnose on 3D-simulated FRF tests: both bending planes excited (docs/diagnose.md).

The truth is the 3D solid (updating.solid) of the smooth bat and of the paper's stepped bat
in data_samples (or, with --bats pro:SEED, a random pro-style white-ash bat with points every
2 in): the handbook wood of meta.json with E_L 5 % above the handbook's, E/G_LR = 11,
E/G_LT = 15, planar grain, uniform density (or, with --billet B, the density
1 + B cos(pi x / L) of a billet denser at one end, which the profile cannot show), a 3 g
accelerometer on the axis at the barrel-end driving point (the last test point, 1 in from
the end; the mesh has a node there). Its roving-hammer FRFs
(updating.simulate.solid_test: bending modes of both planes tapped at 30 degrees from the
radial plane by default, --theta for others: at 45 degrees the first pair is one peak;
0 is a single-plane test; the rigid body on two 150 N/m bungees, 0.5-1.4 % damping rising with
frequency, 0.5 % relative and 0.1 % floor noise, 0-3200 Hz at 0.5 Hz) are written to a UFF
file with meta.json (the scale weight: the solid without its accelerometer) and the profile
the lab would measure on the solid bat (a hexahedral mesh of revolution turns each step into
a 2.5 mm taper, updating.solid.mesh: the stepped bat's profile.csv gets those tapers; with
--exact-steps it keeps the paper's steps, a bat 0.23 % heavier at the barrel step than the
solid), and the real command line runs on them:

    batlab diagnose --profile profile.csv --meta meta.json --frf test.uff --json [--solid]

three times per bat: the 1D family, with --solid, and with --solid and the accelerometer's
data-sheet mass in meta.json (accelerometer_mass_g = 3). For each: the errors of E, the two
planes' E/G, the tap angle and the sensor mass (with the standard uncertainty diagnose
states), the accelerometer from the mass line, the mode shifts and both together
(``sensor_mass_estimate``) against the truth, in g and in their stated standard
uncertainties (z), the RMS error before and after, the named causes and their gains against
the RMS drop, the time. The 3D truth's modes are cached (an .npz keyed by every input, under
$BATLAB_CACHE or ~/.cache/batlab): the first run solves them (about a minute per bat).

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_solid_diagnose.py [--seeds N ...]
        [--theta D ...] [--bats NAME|pro:SEED ...] [--billet B ...] [--no-sheet]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ema.io.uff import write_uff  # noqa: E402
from updating.model.lab_input import read_meta  # noqa: E402
from updating.model.profile import (  # noqa: E402
    Profile,
    make_profile,
    read_profile_csv,
    write_profile_csv,
)
from updating.model.units import IN_TO_M, LB_TO_KG, PSI_TO_PA  # noqa: E402
from updating.simulate.solid_test import tap_test_frf  # noqa: E402
from updating.solid.elastic import OrthotropicWood  # noqa: E402
from updating.solid.mesh import bat_mesh  # noqa: E402
from updating.solid.modes import SolidModes, solid_modes  # noqa: E402

SENSOR_KG = 3e-3
THETA_DEG = 30.0
MESH = (40, 2, 1)  # axial, section, ring divisions (updating.solid.mesh.bat_mesh)
N_MODES = 40
STEP_M = 0.0025  # updating.solid.mesh.bat_mesh's transition replacing a step


def solid_profile(profile: Profile) -> Profile:
    """The profile of the bat the solid mesh represents: each step (two stations at one x) a
    taper over the mesh's step length (updating.solid.mesh.axial_nodes)."""
    x = profile.x_m.astype(float).copy()
    for i in np.flatnonzero(np.diff(x) == 0):
        x[i + 1] = x[i] + STEP_M
    return make_profile(x, profile.diameter_m)


def with_station(profile: Profile, x_m: float) -> Profile:
    """The same solid with a station at ``x_m`` (its diameter interpolated), so the mesh has an
    axis node there: the accelerometer sits at the driving point itself, not at the node
    nearest it (4.4 mm beyond it on the stepped bat, a 3 g mass seen as 3.07 g)."""
    x = np.asarray(profile.x_m, dtype=float)
    if np.any(np.isclose(x, x_m, rtol=0.0, atol=1e-9)):
        return profile
    d = np.asarray(profile.diameter_m, dtype=float)
    i = int(np.searchsorted(x, x_m))
    return make_profile(np.insert(x, i, x_m), np.insert(d, i, np.interp(x_m, x, d)))


def pro_bat(seed: int, folder: Path) -> Path:
    """Write a random pro-style white-ash bat (updating.simulate.fleet.pro_profile, the
    handbook wood, test points every 2 in from 1 in and 1 in from the barrel end) as
    profile.csv and meta.json in ``folder``; return it."""
    from updating.simulate.fleet import SPECIES, pro_profile

    profile = pro_profile(np.random.default_rng(seed))
    length_in = profile.length_m / IN_TO_M
    points_in = np.append(np.arange(1.0, length_in - 1.5, 2.0), round(length_in - 1.0, 2))
    e_psi, weight_density = SPECIES["white ash"]
    folder.mkdir(parents=True, exist_ok=True)
    write_profile_csv(folder / "profile.csv", profile)
    (folder / "meta.json").write_text(json.dumps({
        "serial": f"PRO-{seed}", "species": "white ash", "nominal_E_psi": e_psi,
        "nominal_weight_density_lbf_in3": round(weight_density, 5), "weight_lb": 2.0,
        "points_in": [round(float(p), 3) for p in points_in]}))
    return folder


def cache_dir() -> Path:
    return Path(os.environ.get("BATLAB_CACHE", Path.home() / ".cache" / "batlab")) / "solid"


def cached_solid_modes(profile, wood: OrthotropicWood, sensor_x_m: float,
                       billet: float = 0.0) -> SolidModes:
    """The solid's modes with the accelerometer, from the cache when the same inputs were
    solved before (key: profile, wood, mesh, mode count, sensor, billet).

    ``billet``: the density 1 + billet cos(pi x / L) along the bat (denser at the knob when
    positive), the half-wave of updating.simulate.wood.billet_field, which diagnose's
    uniform-density profile cannot know."""
    key = hashlib.sha1(json.dumps({
        "x": np.asarray(profile.x_m).tolist(), "d": np.asarray(profile.diameter_m).tolist(),
        "wood": repr(wood), "mesh": MESH, "n": N_MODES, "sensor": [sensor_x_m, SENSOR_KG],
        "node at the sensor": True, **({"billet": billet} if billet else {}),
    }, sort_keys=True).encode()).hexdigest()[:16]
    path = cache_dir() / f"{key}.npz"
    if path.exists():
        z = np.load(path)
        return SolidModes(z["freq_hz"], z["kind"], z["axis_x_m"], z["axis_w"], int(z["n_dof"]),
                          tuple(float(v) for v in z["rigid"]))
    length = float(profile.length_m)
    modes = solid_modes(bat_mesh(with_station(profile, sensor_x_m), *MESH), wood, N_MODES,
                        "planar", progress=True, point_masses=((sensor_x_m, SENSOR_KG),),
                        density_factor=(lambda x: 1.0 + billet * np.cos(np.pi * x / length))
                        if billet else None)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, freq_hz=modes.freq_hz, kind=modes.kind, axis_x_m=modes.axis_x_m,
             axis_w=modes.axis_w, n_dof=modes.n_dof, rigid=np.array(modes.rigid))
    tmp.replace(path)
    return modes


def diagnose_cli(folder: Path, solid: bool) -> tuple[dict, float]:
    cmd = [sys.executable, "-m", "batlab", "diagnose", "--profile", str(folder / "profile.csv"),
           "--meta", str(folder / "meta.json"), "--frf", str(folder / "test.uff"), "--json"]
    t0 = time.perf_counter()
    out = subprocess.run(cmd + (["--solid"] if solid else []), capture_output=True, text=True,
                         cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT),
                                        "OPENBLAS_NUM_THREADS": "1"})
    if out.returncode:
        raise SystemExit(f"batlab diagnose failed: {out.stderr.strip()}")
    return json.loads(out.stdout), time.perf_counter() - t0


def report(label: str, out: dict, seconds: float, truth: OrthotropicWood) -> dict:
    cal = out["calibrated"]
    e_err = 100 * (cal["E_psi"] * PSI_TO_PA / truth.E_L_pa - 1)
    eg1, eg2 = cal["E_over_G"], cal.get("E_over_G_plane2") or float("nan")
    sensor = next((c for c in out["causes"] if c["name"] == "sensor_mass"), None)
    std = sensor["uncertainty"]["mass_g"] if sensor else None
    rms = out["rms_error_pct"]
    gains = sum(c["gain_pct"] for c in out["causes"])
    path = gains + sum(c["gain_pct"] for c in out["not_named"] if c["in_reference"])
    print(f"\n{label}: {seconds:.0f} s")
    print(f"  E error {e_err:+.2f} %, E/G plane 1 {eg1:.2f} ({100 * (eg1 / 11 - 1):+.1f} %), "
          f"plane 2 {eg2:.2f} ({100 * (eg2 / 15 - 1):+.1f} %), tap angle "
          f"{cal.get('tap_angle_deg') or float('nan'):.1f} deg, sensor "
          f"{cal['sensor_mass_g']:.2f} g (true {1e3 * SENSOR_KG:g}"
          + (f"; named, +- {std:.2f} g" if std is not None else "") + ")")
    print(f"  RMS nominal {rms['nominal']:.3f} % -> calibrated {rms['extended']:.3f} % (drop "
          f"{rms['nominal'] - rms['extended']:.3f} pp); named gains sum to {gains:.3f} pp, "
          f"the whole path to {path:.3f} pp")
    est = out.get("sensor_mass_estimate") or {}
    parts = [f"{k} {v['mass_g']:.2f} +- {v['std_g']:.2f} g" for k, v in est.items() if v]
    if parts:
        print("  accelerometer: " + ", ".join(parts))
    for c in out["causes"]:
        print(f"  cause {c['name']:<18} gain {c['gain_pct']:.3f} pp  {c['value']}")
    for c in out["not_named"]:
        if c["in_reference"]:
            print(f"  in the model, not named: {c['name']} ({c['gain_pct']:+.3f} pp)")
    for w in out["warnings"]:
        print(f"  warning: {w}")
    sys.stdout.flush()
    return {"E %": e_err, "E/G 1 %": 100 * (eg1 / 11 - 1), "E/G 2 %": 100 * (eg2 / 15 - 1),
            "angle": cal.get("tap_angle_deg") or float("nan"),
            "sensor g": cal["sensor_mass_g"] - 1e3 * SENSOR_KG,
            **accelerometer_errors(est), "RMS nom": rms["nominal"],
            "RMS cal": rms["extended"], "named sum": gains,
            "drop": rms["nominal"] - rms["extended"], "s": seconds}


def accelerometer_errors(est: dict) -> dict:
    """The mass line's, the shifts' and the combined estimate's errors against the truth, g,
    and in their stated standard uncertainties (z)."""
    out = {}
    for key, label in (("mass_line", "ML"), ("mode_shifts", "shifts"), ("combined", "ML+shift")):
        e = est.get(key) or {"mass_g": float("nan"), "std_g": float("nan")}
        err = e["mass_g"] - 1e3 * SENSOR_KG
        out[f"{label} g"], out[f"{label} z"] = err, err / e["std_g"]
    return out


def run(bat: Path, seed: int, exact_steps: bool, with_sheet: bool = True,
        theta_deg: float = THETA_DEG, billet: float = 0.0) -> list:
    given = read_profile_csv(bat / "profile.csv")
    profile = solid_profile(given)
    meta_raw = json.loads((bat / "meta.json").read_text())
    meta = read_meta(bat / "meta.json")
    hb = meta.material
    truth = OrthotropicWood(hb.E_pa * 1.05, hb.rho_kg_m3, e_over_g_lr=11.0, e_over_g_lt=15.0)
    points = np.asarray(meta.points_m)
    t0 = time.perf_counter()
    modes = cached_solid_modes(profile, truth, float(points[-1]), billet)
    test = tap_test_frf(modes, points, points.size - 1, theta_deg, seed=seed)
    print(f"3D truth: {modes.n_dof} DOF, {np.sum(np.char.startswith(modes.kind, 'bend'))} "
          f"bending modes to {modes.freq_hz.max():.0f} Hz, mass {modes.rigid[0]:.4f} kg "
          f"with the accelerometer; {time.perf_counter() - t0:.0f} s (cache: {cache_dir()})")
    bare_kg = modes.rigid[0] - SENSOR_KG  # the scale weighs the bat without its sensor
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        if exact_steps:
            shutil.copy(bat / "profile.csv", folder / "profile.csv")
        else:
            write_profile_csv(folder / "profile.csv", profile)
        write_uff(folder / "test.uff", test)
        runs = (("1D family", False, None), ("--solid", True, None),
                ("--solid, meta.json accelerometer_mass_g = 3", True, 1e3 * SENSOR_KG))
        rows = []
        for label, solid, sheet in runs[:3 if with_sheet else 2]:
            raw = {**meta_raw, "weight_lb": round(bare_kg / LB_TO_KG, 4)}
            if sheet is not None:
                raw["accelerometer_mass_g"] = sheet
            (folder / "meta.json").write_text(json.dumps(raw))
            out, seconds = diagnose_cli(folder, solid)
            rows.append((f"{bat.name} {theta_deg:g} deg seed {seed}: {label}",
                         report(label, out, seconds, truth)))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="*", default=[7], help="noise seeds of the FRFs")
    ap.add_argument("--no-sheet", action="store_true",
                    help="skip the run with the data-sheet accelerometer mass")
    ap.add_argument("--bats", nargs="*", default=["smooth_bat", "paper_bat"],
                    help="bats of data_samples/, or pro:SEED for a random pro-style white-ash "
                         "bat (updating.simulate.fleet.pro_profile)")
    ap.add_argument("--theta", type=float, nargs="*", default=[THETA_DEG],
                    help="tap angles from the radial plane, deg (0: one plane)")
    ap.add_argument("--billet", type=float, nargs="*", default=[0.0],
                    help="density gradients along the solid: 1 + B cos(pi x / L), B = 0.03 "
                         "3 %% denser at the knob, 3 %% lighter at the barrel end")
    ap.add_argument("--exact-steps", action="store_true",
                    help="give diagnose the paper's exact steps, not the solid's tapers")
    args = ap.parse_args()
    rows = []
    for name in args.bats:
        folder = (pro_bat(int(name[4:]), Path(tempfile.mkdtemp()) / name)
                  if name.startswith("pro:") else ROOT / "data_samples" / name)
        for billet in args.billet:
            for seed in args.seeds:
                for theta in args.theta:
                    print(f"\n=== {name} (seed {seed}, tapped at {theta:g} deg"
                          f"{', exact steps' if args.exact_steps else ''}"
                          f"{f', billet {billet:+g}' if billet else ''})")
                    got = run(folder, seed, args.exact_steps, not args.no_sheet, theta, billet)
                    rows += [(label + (f" billet {billet:+g}" if billet else ""), row)
                             for label, row in got]
    print("\nsummary (errors against the truth; sensor in g, the rest in %)")
    keys = list(rows[0][1])
    print(f"{'run':<62}" + "".join(f"{k:>11}" for k in keys))
    for label, row in rows:
        print(f"{label:<62}" + "".join(f"{row[k]:>11.3f}" for k in keys))


if __name__ == "__main__":
    main()
