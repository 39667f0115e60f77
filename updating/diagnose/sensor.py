"""The accelerometer's mass from the mass line and the mode shifts together.

Two independent views of the mass at the driving point (ema.shapes.mass_line):

- the driving point's mass line, against the bare bat's (the profile at the density the
  scale weight gives, ``rigid_flexibility`` without the accelerometer): m = 1/a_d - 1/a_0;
- every mode's frequency shift at the accelerometer's node, d ln f_r = -1/2 m phi_r(x_s)^2,
  against the calibrated model without the accelerometer, with E free (a shift common to
  every mode is the modulus's). The calibrated model's residual RMS is counted in each
  mode's uncertainty: what the model family lacks bounds what the shifts can say.

The mass line's a_0 rests on the profile at uniform density. A billet is denser at one end
than the other by a few percent in a smooth gradient no profile shows (docs/bat_physics.md),
and that moves a_0: its standard uncertainty under the gradients of ``billet_spread`` is
counted in the mass line's (1.3-1.5 g on the sample and random pro bats, where the fit's
own is 0.1-0.2 g: a billet 3 % lighter at the barrel end reads about 2 g low on the 3D
bats, benchmarks/bench_solid_diagnose.py --billet). The same gradients change the modes in
a pattern the shifts partly read as an accelerometer (a denser barrel end is much like a
mass there): ``billet_shift_spread`` counts that in the shifts' uncertainty (several g).
They are combined weighted by their inverse variances; the shifts check the mass line, and
carry the estimate when the test gave no mass line.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ema.shapes.mass_line import (
    MassEstimate,
    combine_masses,
    sensor_mass_from_mass_line,
    sensor_mass_from_shifts,
)
from updating.diagnose.calibration import DiagnosisFit, Observations, columns
from updating.diagnose.model import Setup, modal_sensitivities, rigid_flexibility
from updating.model.assembly import build_model
from updating.model.mass_properties import mass_properties, rigid_mass_line
from updating.model.material import Material

BILLET_DENSITY_AMPLITUDE = 0.03
"""Largest amplitude of a billet's density gradient along the bat, 1 + a cos(pi x / L +
phase) (docs/bat_physics.md: a few percent, smooth; the virtual rig's billets,
``updating.simulate.nuisances.draw_billet``, draw the same)."""
BILLET_PHASES = 12
"""Phases in [0, pi) over which ``billet_spread`` and ``billet_shift_spread`` average."""


def _billet_phases() -> np.ndarray:
    return np.linspace(0.0, np.pi, BILLET_PHASES, endpoint=False)


def _billet(setup: Setup, amplitude: float, phase: float):
    """Return the density factor 1 + a cos(pi x / L + phase) along the bat."""
    length = setup.profile.length_m
    return lambda x: 1.0 + amplitude * np.cos(np.pi * np.asarray(x) / length + phase)


def billet_spread(setup: Setup) -> float:
    """Return the relative standard uncertainty of a_0, the bare bat's mass line at x_s.

    The profile's mass distribution at uniform density is what a_0 is computed from; a
    billet's density 1 + a cos(pi x / L + phase), the amplitude uniform within
    +-``BILLET_DENSITY_AMPLITUDE`` and the phase uniform, at the same total mass (the scale
    weighs the bat), moves it. a_0 = 1/m + (x_s - x_cg)^2 / I_cg is nearly linear in a, so its
    standard deviation is A / sqrt(3) times the RMS over phases of d ln a_0 / d a (a finite
    difference at a = A on ``BILLET_PHASES`` phases).

    Parameters
    ----------
    setup : Setup
        The bat (its profile) and its test (the driving point x_s).

    Returns
    -------
    float
        std(a_0) / a_0.
    """
    model = build_model(setup.profile, Material(1.0, 1.0))
    xs, amp = setup.sensor_x_m, BILLET_DENSITY_AMPLITUDE

    def ln_a0(a: float, phase: float) -> float:
        mp = mass_properties(model, density_factor=_billet(setup, a, phase))
        scale = setup.unit_mass.mass_kg / mp.mass_kg  # the same weight on the scale
        return float(np.log(rigid_mass_line(replace(mp, mass_kg=mp.mass_kg * scale,
                                                    i_cg_kg_m2=mp.i_cg_kg_m2 * scale),
                                            xs, xs)))

    base = ln_a0(0.0, 0.0)
    slopes = [(ln_a0(amp, p) - base) / amp for p in _billet_phases()]
    return float(amp / np.sqrt(3.0) * np.sqrt(np.mean(np.square(slopes))))


def billet_shift_spread(setup: Setup, active: frozenset, bare, n_modes: int, idx: np.ndarray,
                        per_g: np.ndarray, sigma: float) -> float:
    """Return the standard uncertainty (kg) a billet's gradient gives the shifts' estimate.

    The model's frequencies with the density of ``billet_spread``'s gradients (at the same
    total mass, ``model.build``) differ from the uniform model's by a pattern that the
    shifts read, in part, as an accelerometer (``sensor_mass_from_shifts``, c free): what
    amplitude A reads, per A, RMS over the phases, times A / sqrt(3).

    Parameters
    ----------
    setup : Setup
        The bat and its test.
    active : frozenset
        The calibrated model's extensions (the accelerometer's switched on).
    bare : State
        Its values, the accelerometer at 0.
    n_modes : int
        Model modes solved.
    idx : ndarray
        The paired model columns.
    per_g : ndarray
        d ln f / d m of those columns, per gram.
    sigma : float
        Each mode's relative frequency uncertainty.

    Returns
    -------
    float
        The standard uncertainty, kg.
    """
    amp = BILLET_DENSITY_AMPLITUDE
    f0 = modal_sensitivities(setup, active, bare, n_modes).elastic_hz[idx]
    reads = []
    for phase in _billet_phases():
        dense = replace(setup, density_factor=_billet(setup, amp, phase))
        f = modal_sensitivities(dense, active, bare, n_modes).elastic_hz[idx]
        reads.append(sensor_mass_from_shifts(np.log(f / f0), per_g, sigma).mass_kg / amp)
    return float(amp / np.sqrt(3.0) * np.sqrt(np.mean(np.square(reads))))


@dataclass(frozen=True)
class SensorMass:
    """The accelerometer's mass, kg: from the mass line, from the shifts, and combined.

    ``mass_line`` is None when the test gave none.
    """

    mass_line: MassEstimate | None
    shifts: MassEstimate
    combined: MassEstimate

    def to_json_dict(self) -> dict:
        """Return the grams and standard uncertainties (null where not estimated)."""
        def grams(e: MassEstimate | None) -> dict | None:
            if e is None or not np.isfinite(e.std_kg):
                return None
            return {"mass_g": 1e3 * e.mass_kg, "std_g": 1e3 * e.std_kg}

        return {"mass_line": grams(self.mass_line), "mode_shifts": grams(self.shifts),
                "combined": grams(self.combined)}


def estimate_sensor_mass(setup: Setup, obs: Observations, final: DiagnosisFit) -> SensorMass:
    """Estimate the accelerometer's mass from the test's mass line and mode shifts.

    Parameters
    ----------
    setup : Setup
        The bat and its test.
    obs : Observations
        The paired measured modes and the mass line.
    final : DiagnosisFit
        The calibrated model (its extensions and parameter values; the accelerometer is
        switched on and set to 0 for the shifts).

    Returns
    -------
    SensorMass
        The two estimates and their combination.
    """
    active = final.active | {"sensor_mass", "density"}
    bare = replace(final.state, sensor_mass_kg=0.0)
    drive = int(np.argmin(np.abs(setup.points_m - setup.sensor_x_m)))
    ml = None
    if obs.mass_line is not None:
        a0 = float(rigid_flexibility(setup, active, bare)[0][drive])
        ml = sensor_mass_from_mass_line(obs.mass_line, setup.points_m, setup.sensor_x_m,
                                        obs.sigma_ml, a0)
        # m = 1/a_d - 1/a_0: std(a_0) / a_0^2 from the billet's unknown gradient
        ml = replace(ml, std_kg=float(np.hypot(ml.std_kg, billet_spread(setup) / a0)))
    sol = modal_sensitivities(setup, final.active | {"sensor_mass"}, bare, obs.n_model_modes,
                              ("sensor_g",))
    idx = columns(sol, obs)[0]
    rel = np.log(obs.freq_hz / sol.elastic_hz[idx])
    sigma = float(np.hypot(obs.sigma_f, final.rms_pct / 100))
    shifts = sensor_mass_from_shifts(rel, 1e3 * sol.dlnf[0, idx], sigma)
    if np.isfinite(shifts.std_kg):  # the billet's gradient read as an accelerometer
        spread = billet_shift_spread(setup, final.active | {"sensor_mass"}, bare,
                                     obs.n_model_modes, idx, 1e3 * sol.dlnf[0, idx], sigma)
        shifts = replace(shifts, std_kg=float(np.hypot(shifts.std_kg, spread)))
    combined = combine_masses([e for e in (ml, shifts) if e is not None])
    return SensorMass(ml, shifts, combined)


def sensor_note(estimate: SensorMass, final: DiagnosisFit) -> str:
    """Say what the mass line and the mode shifts give together, against the calibrated model.

    They disagree when the calibrated model's accelerometer lies more than 2.5 of the
    combined estimate's standard uncertainties from it (the fitted frequencies' model error,
    taken as noise by the fit, pulls it).
    """
    def text(e: MassEstimate) -> str:
        return f"{1e3 * e.mass_kg:.2f} +- {1e3 * e.std_kg:.2f} g"

    parts = [f"mass line {text(estimate.mass_line)}"] if estimate.mass_line else []
    if np.isfinite(estimate.shifts.std_kg):
        parts.append(f"mode shifts {text(estimate.shifts)}")
    fitted = 1e3 * final.state.sensor_mass_kg if "sensor_mass" in final.active else 0.0
    c = estimate.combined
    agree = abs(fitted - 1e3 * c.mass_kg) <= 2.5 * 1e3 * c.std_kg
    verdict = ("agrees" if agree else
               "disagrees: the model's frequency error, taken as noise by the fit, pulls it; "
               "trust the combined value")
    return (f"accelerometer from the mass line and the mode shifts together: {text(c)} "
            f"({', '.join(parts)}); the calibrated model's {fitted:.2f} g {verdict}")

