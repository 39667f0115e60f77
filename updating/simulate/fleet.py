"""Random pro-style bats and re-test scenarios for hidden-effect tests of the inspection.

Each case is a bat from a model richer than its reference (docs/method.md, real bats): smooth
profile (knob 1.3-1.7 in, handle 0.9-1.0 in, barrel 2.45-2.61 in, length 32-34 in) with
caliper noise on the copy the lab measures, Timoshenko wood with E/G 10-18, a 2-6 g
accelerometer off its labelled point, two bungees, and a re-test with moisture drift (up to
+-1 point of moisture content) and the accelerometer moved (up to 0.1 in). Altered cases
carry a core 0.75-1.25 in wide, 6-11 in deep with a 1 in plug, filled with cork (density
ratio 0.2-0.4), a heavy fill (1.5-2.2) or a density-neutral soft fill (0.9-1.1). The
reference is what a good calibration gives: the truth perturbed by E +-1 %, density
+-0.5 %, E/G +-10 %, sensor mass +-0.3 g, bungee stiffness +-20 %, sensor at its label,
on diagnose's fine mesh (its `geometry` extension: 0.5 in elements).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np

from ema.io.frf_io import write_test
from updating.correlate.measured import MeasuredModes
from updating.model.assembly import build_model
from updating.model.mass_properties import mass_properties
from updating.model.material import Material, material_from_imperial
from updating.model.profile import Profile, make_profile, write_profile_csv
from updating.model.reference import BatReference
from updating.model.sections import Core
from updating.model.units import IN_TO_M, LB_TO_KG
from updating.simulate.virtual_bat import DEFAULT_FREQ_HZ, VirtualBat, simulate_modes, simulate_test

Kind = Literal["none", "cork", "heavy", "neutral"]
"""A fleet bat's alteration: none, or a core filled as in ``FILLS``."""
FILLS = {"cork": (0.2, 0.4), "heavy": (1.5, 2.2), "neutral": (0.9, 1.1)}


@dataclass(frozen=True)
class Case:
    """A bat, its two tests and its calibrated reference."""

    profile: Profile  # the caliper profile the lab has (noisy)
    baseline: VirtualBat
    retest: VirtualBat
    reference: BatReference
    kind: Kind

    @property
    def core(self) -> Core | None:
        """Return the re-test's core (None when unaltered)."""
        return self.retest.core


def smoothstep(t: np.ndarray) -> np.ndarray:
    """Return the smooth step 3 t^2 - 2 t^3 of t clipped to [0, 1]."""
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3 - 2 * t)


def pro_profile(rng: np.random.Generator, caliper_noise_in: float = 0.0) -> Profile:
    """Draw a smooth random pro-style profile, stations every 0.5 in."""
    length = rng.uniform(32.0, 34.0)
    d_knob, d_handle = rng.uniform(1.3, 1.7), rng.uniform(0.9, 1.0)
    d_barrel = rng.uniform(2.45, 2.61)
    t0, t1 = rng.uniform(10.0, 13.0), length - rng.uniform(9.0, 11.5)
    x = np.append(np.arange(0.0, length, 0.5), length)
    d = d_handle + 0.08 * smoothstep(x / t0)
    d = d + (d_barrel - d[-1]) * smoothstep((x - t0) / (t1 - t0))
    d = d + (d_knob - d_handle) * (1 - smoothstep((x - 0.5) / 1.0))
    d = d - 0.12 * smoothstep((x - (length - 0.5)) / 0.5)
    d = d + caliper_noise_in * rng.standard_normal(x.size)
    return make_profile(x * IN_TO_M, d * IN_TO_M, "random bat")


def random_retest(rng: np.random.Generator, base: VirtualBat, kind: Kind) -> VirtualBat:
    """Draw the re-test weeks later.

    A random core of ``kind`` (or none), moisture drift up to +-1 point, the accelerometer
    re-mounted up to 0.1 in from where it was.
    """
    core = None
    if kind != "none":
        lo, hi = FILLS[kind]
        core = Core(rng.uniform(0.75, 1.25) * IN_TO_M, rng.uniform(6.0, 11.0) * IN_TO_M,
                    rng.uniform(lo, hi), 0.0, IN_TO_M)
    return replace(base, core=core, moisture_pct=rng.uniform(-1.0, 1.0),
                   sensor_offset_m=base.sensor_offset_m + rng.uniform(-0.1, 0.1) * IN_TO_M)


def random_case(rng: np.random.Generator, kind: Kind = "none") -> Case:
    """Draw a random bat; ``kind`` "none" (unaltered) or a fill in FILLS."""
    truth_profile = pro_profile(rng)
    profile = Profile(truth_profile.x_m, truth_profile.diameter_m
                      + 0.003 * IN_TO_M * rng.standard_normal(truth_profile.x_m.size))
    E = rng.uniform(1.5e6, 2.1e6) * 6894.757
    rho = rng.uniform(560.0, 660.0)
    e_over_g = rng.uniform(10.0, 18.0)
    L_in = truth_profile.length_m / IN_TO_M
    points = np.append(np.arange(1.0, L_in - 1.5, 2.0), L_in - 1.0) * IN_TO_M
    sensor_mass = rng.uniform(0.002, 0.006)
    bungee = rng.uniform(100.0, 400.0)
    offset = rng.uniform(-0.05, 0.05) * IN_TO_M
    base = VirtualBat(truth_profile, Material(E, rho, e_over_g), points,
                      sensor_offset_m=offset, sensor_mass_kg=sensor_mass,
                      bungee_k_n_per_m=bungee)
    retest = random_retest(rng, base, kind)
    reference = BatReference(
        E * (1 + rng.uniform(-0.01, 0.01)), rho * (1 + rng.uniform(-0.005, 0.005)),
        e_over_g * (1 + rng.uniform(-0.1, 0.1)), beam="timoshenko", rotary_inertia=True,
        sensor_mass_kg=sensor_mass + rng.uniform(-3e-4, 3e-4),
        sensor_x_m=float(points[base.sensor_point()]),
        bungee_k_n_per_m=bungee * (1 + rng.uniform(-0.2, 0.2)),
        element_length_m=base.element_length_m)
    return Case(profile, base, retest, reference, kind)


def case_modes(
    case: Case, rng: np.random.Generator, n_modes: int = 6,
) -> tuple[MeasuredModes, MeasuredModes]:
    """Simulate baseline and re-test modes with realistic noise.

    Frequency noise 0.02-0.05 %, shape entries 1-2 % of the mode's RMS, as a good modal fit
    gives them.
    """
    out = []
    for bat in (case.baseline, case.retest):
        out.append(simulate_modes(bat, n_modes, freq_noise=rng.uniform(2e-4, 5e-4),
                                  shape_noise=rng.uniform(0.01, 0.02),
                                  seed=int(rng.integers(2**31))))
    return out[0], out[1]


SPECIES = {  # handbook values at 12 % moisture (docs/method.md, real bats): E psi, lbf/in^3
    "white ash": (1.74e6, 0.60 * 0.036127),
    "paper birch": (1.60e6, 0.55 * 0.036127),
    "yellow birch": (2.02e6, 0.62 * 0.036127),
    "sugar maple": (1.83e6, 0.63 * 0.036127),
}

def random_wood(rng: np.random.Generator, species: str | None = None) -> tuple[str, Material]:
    """Draw a species (random unless given) and a board of it.

    E is drawn within +-15 % and density within +-8 % of the species' handbook values
    (``SPECIES``), E/G within 10-18.

    Parameters
    ----------
    rng : numpy.random.Generator
        The source of the draws.
    species : str or None
        A key of ``SPECIES``; None draws one.

    Returns
    -------
    species : str
        The species.
    wood : Material
        The board's E (Pa), density (kg/m^3) and E/G.
    """
    if species is None:
        species = list(SPECIES)[int(rng.integers(len(SPECIES)))]
    E_psi, wd = SPECIES[species]
    nominal = material_from_imperial(E_psi, wd)
    wood = Material(nominal.E_pa * rng.uniform(0.85, 1.15),
                    nominal.rho_kg_m3 * rng.uniform(0.92, 1.08), rng.uniform(10.0, 18.0))
    return species, wood


@dataclass(frozen=True)
class LabCase:
    """A bat as a lab receives it: what it writes down and the truth behind its two tests.

    Attributes
    ----------
    profile : Profile
        The caliper profile (noisy copy of the truth's).
    meta : dict
        The content of meta.json: species handbook values (not the truth), the scale weight of the
        real bat (no accelerometer on it), the test points.
    baseline, retest : VirtualBat
        The truth of the two tests (re-test: moisture drift, accelerometer re-mounted, and the
        core if altered).
    kind : Kind
        "none" or a fill in FILLS.
    """

    profile: Profile
    meta: dict
    baseline: VirtualBat
    retest: VirtualBat
    kind: Kind

    @property
    def core(self) -> Core | None:
        """Return the re-test's core (None when unaltered)."""
        return self.retest.core


def lab_case(rng: np.random.Generator, kind: Kind = "none", serial: str = "SIM-0001") -> LabCase:
    """Draw a random bat for the full path (FRF files to verdict), ``kind`` "none" or a fill.

    Truth: a random pro profile, a random species with E within +-15 % and density within
    +-8 % of its handbook values, Timoshenko with E/G 10-18, a 2-6 g accelerometer up to
    0.05 in off its labelled point, two bungees 100-400 N/m, 0.5 % FRF noise; at the re-test,
    moisture drift up to +-1 point and the accelerometer moved up to 0.1 in.
    """
    truth_profile = pro_profile(rng)
    profile = Profile(truth_profile.x_m, truth_profile.diameter_m
                      + 0.003 * IN_TO_M * rng.standard_normal(truth_profile.x_m.size))
    species, wood = random_wood(rng)
    E_psi, wd = SPECIES[species]
    L_in = truth_profile.length_m / IN_TO_M
    points_in = np.append(np.arange(1.0, L_in - 1.5, 2.0), round(L_in - 1.0, 2))
    offset = rng.uniform(-0.05, 0.05) * IN_TO_M
    base = VirtualBat(truth_profile, wood, points_in * IN_TO_M, sensor_offset_m=offset,
                      sensor_mass_kg=rng.uniform(0.002, 0.006),
                      bungee_k_n_per_m=rng.uniform(100.0, 400.0), rel_noise=0.005)
    retest = random_retest(rng, base, kind)
    bare = build_model(truth_profile, wood, beam="timoshenko", element_length_m=0.5 * IN_TO_M)
    weight_lb = mass_properties(bare).mass_kg / LB_TO_KG
    meta = {"serial": serial, "species": species, "nominal_E_psi": E_psi,
            "nominal_weight_density_lbf_in3": round(wd, 5), "weight_lb": round(weight_lb, 4),
            "points_in": [round(float(x), 3) for x in points_in]}
    return LabCase(profile, meta, base, retest, kind)


def write_lab_files(case: LabCase, folder, seed: int, freq_hz=None) -> dict:
    """Write profile.csv, meta.json, baseline.uff and retest.uff into ``folder``.

    As `batlab simulate` writes them; returns their paths by name.
    """
    folder = Path(folder)
    freq = DEFAULT_FREQ_HZ if freq_hz is None else np.asarray(freq_hz, dtype=float)
    paths = {k: folder / n for k, n in (("profile", "profile.csv"), ("meta", "meta.json"),
                                        ("baseline", "baseline.uff"),
                                        ("retest", "retest.uff"))}
    write_profile_csv(paths["profile"], case.profile)
    paths["meta"].write_text(json.dumps(case.meta, indent=1))
    write_test(paths["baseline"], simulate_test(case.baseline, freq, seed=seed))
    write_test(paths["retest"], simulate_test(case.retest, freq, seed=seed + 1))
    return paths
