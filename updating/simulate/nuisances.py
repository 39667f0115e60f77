"""What changes between two tests of one unaltered bat, drawn at realistic magnitudes.

One function per nuisance; each returns the truth's settings for the baseline and the
re-test and a JSON-able record of what it drew. Magnitudes (docs/method.md, "Real bats"):

| nuisance | drawn |
|---|---|
| moisture | middle 0.25-1 point (either sign), 1.5-2x that at each end, decay 1.5-3 in |
| uniform_drift | uniform drift 1.5-2 points (either sign) |
| temperature | baseline 18-26 C, re-test +-10 C from it; E and G -0.1..-0.3 %/C |
| billet | E +-4 %, density +-3 % in a smooth half-wave along the bat (both tests) |
| planes | E/G_LR 9-12, E/G_LT 12-16; tapped at 0-45 deg, re-test +-10 deg from it |
| cup | barrel end cupped 0.25-1 in deep, 1.0-1.6 in across (both tests) |
| noise | FRF noise 1-2 % (else 0.5 %) |
| points | 8-20 evenly spaced impact points (else every 2 in) |
| model_points | the 11-20 points `batlab model --n-points` suggests for the lab's profile |
| band | 0-2000 Hz for both tests on half the bats (else 0-3200 Hz) |
| accelerometer | replaced by one of 2-6 g on half the bats, else re-mounted up to 0.1 in off |
| bungees | re-hung: each bungee's stiffness x 0.7-1.4 |
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from updating.model.sections import Core
from updating.model.units import IN_TO_M
from updating.simulate.wood import (
    WoodField,
    billet_field,
    moisture_field,
    temperature_field,
)

NUISANCES = ("moisture", "temperature", "billet", "planes", "cup", "noise", "points", "band",
             "accelerometer", "bungees")
"""Every nuisance of the default nuisance-rich fleet."""
OPTIONAL_NUISANCES = ("uniform_drift", "model_points", "coherence")
"""Drawn only when asked for. ``coherence`` is not a nuisance but what the lab's files hold:
each test's coherence beside its FRFs, from ``COHERENCE_AVERAGES`` hits a point (its noise
measured, ``ema.shapes.noise``); it draws nothing, so a seed gives the same bat with or
without it."""
COHERENCE_AVERAGES = 5
"""Hits averaged a point when the files carry their coherence."""


def signed(rng: np.random.Generator, lo: float, hi: float) -> float:
    """Draw a magnitude uniform in [lo, hi] with a random sign."""
    return float(rng.uniform(lo, hi) * rng.choice([-1.0, 1.0]))


def draw_moisture(rng: np.random.Generator, length_m: float) -> tuple[WoodField, dict]:
    """End-grain moisture drift at the re-test (the baseline is the reference state)."""
    rec = {"middle_pct": signed(rng, 0.25, 1.0), "knob_end_ratio": rng.uniform(1.5, 2.0),
           "barrel_end_ratio": rng.uniform(1.5, 2.0), "decay_in": rng.uniform(1.5, 3.0)}
    return moisture_field(length_m, **rec), rec


def draw_uniform_drift(rng: np.random.Generator, length_m: float) -> tuple[WoodField, dict]:
    """Draw a uniform moisture drift of 1.5-2 points either way (field and record)."""
    rec = {"middle_pct": signed(rng, 1.5, 2.0)}
    return moisture_field(length_m, rec["middle_pct"]), rec


def draw_temperature(
    rng: np.random.Generator, length_m: float,
) -> tuple[WoodField, WoodField, dict]:
    """(baseline field, re-test field, record); fields relative to 20 C."""
    t_base = rng.uniform(18.0, 26.0)
    t_re = t_base + rng.uniform(-10.0, 10.0)
    per_c = rng.uniform(0.001, 0.003)
    rec = {"baseline_c": t_base, "retest_c": t_re, "per_c": per_c}
    return (temperature_field(length_m, t_base - 20.0, per_c),
            temperature_field(length_m, t_re - 20.0, per_c), rec)


def draw_billet(rng: np.random.Generator, length_m: float) -> tuple[WoodField, dict]:
    """Draw smooth billet gradients: E +-4 %, density +-3 % across the bat (field and record)."""
    rec = {"e_amplitude": rng.uniform(-0.04, 0.04), "rho_amplitude": rng.uniform(-0.03, 0.03),
           "phase": rng.uniform(0.0, np.pi)}
    return billet_field(length_m, **rec), rec


def draw_planes(rng: np.random.Generator) -> tuple[float, float, float, float, dict]:
    """(E/G radial, E/G tangential, baseline theta deg, re-test theta deg, record)."""
    eg_r, eg_t = rng.uniform(9.0, 12.0), rng.uniform(12.0, 16.0)
    th_b = rng.uniform(0.0, 45.0)
    th_r = float(np.clip(th_b + rng.uniform(-10.0, 10.0), 0.0, 90.0))
    rec = {"e_over_g_radial": eg_r, "e_over_g_tangential": eg_t, "baseline_theta_deg": th_b,
           "retest_theta_deg": th_r}
    return eg_r, eg_t, th_b, th_r, rec


def draw_cup(rng: np.random.Generator) -> tuple[Core, dict]:
    """Draw a cupped barrel end: an empty cavity at the end, plug 0 (cavity and record)."""
    rec = {"depth_in": rng.uniform(0.25, 1.0), "diameter_in": rng.uniform(1.0, 1.6)}
    return Core(rec["diameter_in"] * IN_TO_M, rec["depth_in"] * IN_TO_M, 0.0, 0.0, 0.0), rec


def draw_noise(rng: np.random.Generator) -> float:
    """Draw the FRF noise, 1-2 % of the FRF."""
    return float(rng.uniform(0.01, 0.02))


def even_points_in(length_in: float, n: int) -> np.ndarray:
    """``n`` impact points from 1 in to 1 in short of the barrel end (the driving point)."""
    return np.round(np.linspace(1.0, length_in - 1.0, n), 2)


def lab_points_in(length_in: float) -> np.ndarray:
    """Return the usual layout: every 2 in from 1 in, and the driving point 1 in from the end."""
    return np.append(np.arange(1.0, length_in - 1.5, 2.0), round(length_in - 1.0, 2))


def draw_points(rng: np.random.Generator, length_in: float) -> np.ndarray:
    """Draw an even layout of 8-20 points, in."""
    return even_points_in(length_in, int(rng.integers(8, 21)))


def draw_model_points(rng: np.random.Generator, profile, material) -> np.ndarray:
    """Draw the layout `batlab model --n-points N` suggests (N 11-20), in.

    For the lab's profile and the species' handbook wood (Timoshenko, E/G 14).
    """
    from updating.model.assembly import build_model, displacement_at
    from updating.model.modes import model_modes
    from updating.model.placement import suggest_points

    model = build_model(profile, replace(material, e_over_g=14.0), beam="timoshenko")
    shapes = model_modes(model, n_modes=6).elastic().shapes[:, :4]
    layout = suggest_points(profile.length_m, lambda x: displacement_at(model, shapes, x),
                            int(rng.integers(11, 21)))
    return np.round(layout.points_m / IN_TO_M, 2)


def draw_band(rng: np.random.Generator) -> float:
    """Draw the measured band's top: 2 kHz or 3.2 kHz, even odds."""
    return 2000.0 if rng.uniform() < 0.5 else 3200.0


def draw_accelerometer(
    rng: np.random.Generator, mass_kg: float, offset_m: float,
) -> tuple[float, float, dict]:
    """Re-test accelerometer (mass, offset from its labelled point): replaced or re-mounted."""
    replaced = bool(rng.uniform() < 0.5)
    new_mass = rng.uniform(0.002, 0.006) if replaced else mass_kg
    new_offset = offset_m + rng.uniform(-0.1, 0.1) * IN_TO_M
    rec = {"replaced": replaced, "baseline_g": 1e3 * mass_kg, "retest_g": 1e3 * new_mass,
           "shift_in": (new_offset - offset_m) / IN_TO_M}
    return new_mass, new_offset, rec


def draw_bungees(rng: np.random.Generator, k_n_per_m: float) -> tuple[float, dict]:
    """Draw re-hung bungees: the stiffness times 0.7-1.4 (stiffness and record)."""
    factor = rng.uniform(0.7, 1.4)
    return k_n_per_m * factor, {"stiffness_factor": factor}


def combine(*fields: WoodField | None) -> WoodField | None:
    """Multiply the fields given (None when none is)."""
    out = None
    for f in fields:
        if f is not None:
            out = f if out is None else out.times(f)
    return out

