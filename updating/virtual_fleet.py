"""Random pro-style bats and re-test scenarios for hidden-effect tests of the inspection.

Each case is a bat from a model richer than its reference (../shared/BAT_PHYSICS.md): smooth
profile (knob 1.3-1.7 in, handle 0.9-1.0 in, barrel 2.45-2.61 in, length 32-34 in) with
caliper noise on the copy the lab measures, Timoshenko wood with E/G 10-18, a 2-6 g
accelerometer off its labelled point, two bungees, and a re-test with moisture drift (up to
+-1 point of moisture content) and the accelerometer moved (up to 0.1 in). Altered cases
carry a core 0.75-1.25 in wide, 6-11 in deep with a 1 in plug, filled with cork (density
ratio 0.2-0.4), a heavy fill (1.5-2.2) or a density-neutral soft fill (0.9-1.1). The
reference is what a good calibration gives: the truth perturbed by E +-1 %, density
+-0.5 %, E/G +-10 %, sensor mass +-0.3 g, bungee stiffness +-20 %, sensor at its label.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from updating.calibration import BatReference
from updating.material import Material
from updating.measured import MeasuredModes
from updating.profile import Profile, make_profile
from updating.sections import Core
from updating.units import IN_TO_M
from updating.virtual_bat import VirtualBat, simulate_modes

FILLS = {"cork": (0.2, 0.4), "heavy": (1.5, 2.2), "neutral": (0.9, 1.1)}


@dataclass(frozen=True)
class Case:
    """A bat, its two tests and its calibrated reference."""

    profile: Profile  # the caliper profile the lab has (noisy)
    baseline: VirtualBat
    retest: VirtualBat
    reference: BatReference
    kind: str  # "none", "cork", "heavy" or "neutral"

    @property
    def core(self) -> Core | None:
        return self.retest.core


def smoothstep(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3 - 2 * t)


def pro_profile(rng: np.random.Generator, caliper_noise_in: float = 0.0) -> Profile:
    """A smooth random pro-style profile, stations every 0.5 in."""
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


def random_case(rng: np.random.Generator, kind: str = "none") -> Case:
    """A random bat; ``kind`` "none" (unaltered) or a fill in FILLS."""
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
    core = None
    if kind != "none":
        lo, hi = FILLS[kind]
        core = Core(rng.uniform(0.75, 1.25) * IN_TO_M, rng.uniform(6.0, 11.0) * IN_TO_M,
                    rng.uniform(lo, hi), 0.0, IN_TO_M)
    retest = replace(base, core=core, moisture_pct=rng.uniform(-1.0, 1.0),
                     sensor_offset_m=offset + rng.uniform(-0.1, 0.1) * IN_TO_M)
    reference = BatReference(
        E * (1 + rng.uniform(-0.01, 0.01)), rho * (1 + rng.uniform(-0.005, 0.005)),
        e_over_g * (1 + rng.uniform(-0.1, 0.1)), beam="timoshenko", rotary_inertia=True,
        sensor_mass_kg=sensor_mass + rng.uniform(-3e-4, 3e-4),
        sensor_x_m=float(points[base.sensor_point()]),
        bungee_k_n_per_m=bungee * (1 + rng.uniform(-0.2, 0.2)))
    return Case(profile, base, retest, reference, kind)


def case_modes(
    case: Case, rng: np.random.Generator, n_modes: int = 6,
) -> tuple[MeasuredModes, MeasuredModes]:
    """Baseline and re-test modes with realistic noise (frequency 0.02-0.05 %, shape entries
    1-2 % of the mode's RMS), as a good modal fit gives them."""
    out = []
    for bat in (case.baseline, case.retest):
        out.append(simulate_modes(bat, n_modes, freq_noise=rng.uniform(2e-4, 5e-4),
                                  shape_noise=rng.uniform(0.01, 0.02),
                                  seed=int(rng.integers(2**31))))
    return out[0], out[1]
