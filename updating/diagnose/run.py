"""Diagnose: what the paper's model gets wrong about a bat's baseline test, why, and the fix.

1. Pair the measured modes with the nominal model's (Euler-Bernoulli, isotropic, handbook E
   and density, ~1 in elements, nothing attached) by MAC.
2. Causes, by forward selection: from the nominal model, try each remaining extension
   (updating.diagnose.model.CAUSES), refit all free parameters (updating.diagnose.calibration), keep
   the one that lowers the RMS frequency error most. Its gain (percentage points) is measured,
   not assumed. It counts only if the gain is at least ``min_gain_pct`` and significant given
   the frequency uncertainty: the drop of the frequency chi-square sum(e_r^2) / sigma_f^2
   exceeds the 99 % point of chi-square with as many degrees of freedom as new parameters (at
   least one). The selection stops at the first extension that fails.
3. What was measured rather than fitted joins next: the density from the scale weight and,
   when the test saw them, the bungees from the suspension modes.
4. Calibration: further extensions join while they improve the fit of frequencies and
   mass-normalised shapes by more than they cost (Akaike: chi-square drop above 2 per
   parameter); the accelerometer's mass is mostly seen here, in the shapes.
Every extension of the calibrated model has its measured frequency gain; those whose gain
qualifies as in 2 are named causes.
5. Backward check: each named cause is removed from the calibrated model in turn; if that
   costs less than the naming test of 2 (the greedy order let it stand in for later ones) it
   is not named, and it leaves the model unless the Akaike test of 4 keeps it.
6. Pairing checks (``updating.diagnose.pairing_check``): low-MAC pairs, skipped model modes and
   parameters at their bounds are reported in ``warnings``, and then no cause is named;
   unreliable shapes are paired in frequency order, with a warning.
The calibrated model is the bat's reference for inspect.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ema.shapes.mac import mac
from updating.correlate.measured import MeasuredModes
from updating.correlate.pairing import pair_modes
from updating.diagnose.calibration import DiagnosisFit, Observations, fit_model, shape_sigma
from updating.diagnose.model import (
    BOUNDS,
    CAUSES,
    Setup,
    State,
    free_parameters,
    modal_sensitivities,
    reference_of,
    rigid_flexibility,
)
from updating.diagnose.pairing_check import checked_pairing, pairing_warnings, refuse_causes
from updating.diagnose.plane_pairs import (
    BOTH_IN_ONE,
    PLANE_1,
    PLANE_2,
    SEEN_ONCE,
    plane_codes,
)
from updating.diagnose.sensor import (
    SensorMass,
    billet_spread,
    estimate_sensor_mass,
    sensor_note,
)
from updating.model.lab_input import BatMeta
from updating.model.profile import Profile
from updating.model.reference import BatReference
from updating.model.units import IN_TO_M, LBF_IN3_TO_KG_M3, PSI_TO_PA
from updating.tails import chi2_ppf

MIN_GAIN_PCT = 0.05
FINE_ELEMENT_IN = 0.5
CONFIDENCE = 0.99


@dataclass(frozen=True)
class Step:
    """One extension tried in the forward selection, and the fit with it added.

    role: "cause" (named), "calibration" (in the calibrated model, its frequency gain too
    small to name) or "rejected". chi2_drop_freq / chi2_drop: drop of the frequency /
    frequency-and-shape chi-square; new_params: parameters it added (at least 1).
    """

    name: str
    rms_before_pct: float
    rms_after_pct: float
    chi2_drop_freq: float
    chi2_drop: float
    new_params: int
    role: str
    fit: DiagnosisFit

    @property
    def named(self) -> bool:
        """Return whether the extension is named a cause."""
        return self.role == "cause"

    @property
    def gain_pct(self) -> float:
        """Return the drop of the RMS frequency error the extension brought, percentage points."""
        return self.rms_before_pct - self.rms_after_pct


@dataclass(frozen=True)
class Diagnosis:
    """Result of diagnose().

    Attributes
    ----------
    measured_hz : np.ndarray
        (m,) paired measured frequencies, Hz (ascending).
    measured_index : np.ndarray
        (m,) their index in the measured modes.
    model_index : np.ndarray
        (m,) the paired elastic mode of the model (0: the first).
    nominal, extended : DiagnosisFit
        Fit of the nominal model (no parameters) and of the calibrated model.
    steps : tuple[Step, ...]
        The selection path, each extension with its measured gain, in the order added (their
        gains add up to the drop from the nominal to the calibrated RMS error, up to the small
        shifts when the shape weights are re-estimated), then the extensions left out (role
        "rejected").
    unpaired_hz : np.ndarray
        Measured modes no model mode matched (MAC below the threshold).
    min_gain_pct : float
        Naming threshold, percentage points.
    reference : BatReference
        The calibrated reference (updating.model.reference.BatReference).
    fine_element_m : float
        Element length of the 'geometry' extension, m.
    warnings : tuple[str, ...]
        What the diagnosis could not establish, one sentence each: pairing problems
        (``updating.diagnose.pairing_check``; when one makes the pairing untrustworthy no cause
        is named) and the limits of the calibration.
    n_split : int
        Measured bending pairs with both planes' members seen.
    n_in_one_peak : int
        Measured modes holding both planes' members in one peak (compared with their mix).
    sensor : SensorMass | None
        The accelerometer's mass from the mass line and the mode shifts
        (``updating.diagnose.sensor``).
    """

    measured_hz: np.ndarray
    measured_index: np.ndarray
    model_index: np.ndarray
    nominal: DiagnosisFit
    extended: DiagnosisFit
    steps: tuple[Step, ...]
    unpaired_hz: np.ndarray
    min_gain_pct: float
    reference: BatReference
    fine_element_m: float = FINE_ELEMENT_IN * IN_TO_M
    warnings: tuple[str, ...] = ()
    n_split: int = 0
    n_in_one_peak: int = 0
    sensor: SensorMass | None = None

    @property
    def causes(self) -> tuple[Step, ...]:
        """Named causes, largest gain first."""
        return tuple(sorted((s for s in self.steps if s.named), key=lambda s: -s.gain_pct))

    def cause_value(self, name: str) -> tuple[dict, dict]:
        """Return a cause's value and standard uncertainty in the contract's units.

        Both from the calibrated model.
        """
        ref, fit = self.reference, self.extended

        def rel_std(par: str) -> float:
            return fit.std(par) if par in fit.names else 0.0

        if name == "modulus":
            e_psi = ref.E_pa / PSI_TO_PA
            return {"E_psi": e_psi}, {"E_psi": e_psi * rel_std("ln_E")}
        if name == "density":
            wd = ref.rho_kg_m3 / LBF_IN3_TO_KG_M3
            return ({"weight_density_lbf_in3": wd},
                    {"weight_density_lbf_in3": wd * rel_std("ln_rho")})
        if name == "shear_deformation":
            return ({"E_over_G": ref.e_over_g},
                    {"E_over_G": ref.e_over_g * rel_std("ln_e_over_g")})
        if name == "sensor_mass":
            return {"mass_g": 1e3 * ref.sensor_mass_kg}, {"mass_g": rel_std("sensor_g")}
        if name == "suspension":
            return ({"k_n_per_m": ref.bungee_k_n_per_m},
                    {"k_n_per_m": 1e3 * rel_std("bungee_kn_per_m")})
        if name == "geometry":
            return ({"element_length_in": self.fine_element_m / IN_TO_M,
                     "nodes_at_test_points": True}, {})
        if name == "shear_coefficient":
            return {"formula": ref.shear_coefficient}, {}
        if name == "two_planes":
            eg2 = ref.e_over_g_plane2
            return ({"E_over_G_plane2": eg2, "E_over_G": ref.e_over_g,
                     "tap_angle_deg": ref.tap_angle_deg, "pairs_split": self.n_split,
                     "pairs_in_one_peak": self.n_in_one_peak},
                    {"E_over_G_plane2": eg2 * rel_std("ln_g_ratio"),
                     "tap_angle_deg": float(np.degrees(rel_std("theta")))})
        if name == "beam_theory":
            c = np.atleast_2d(np.asarray(ref.beam_theory_corrections or (), dtype=float))
            return {"corrections_pct": (100 * c).tolist()}, {}
        return {}, {}

    def to_json_dict(self) -> dict:
        """Return the contract's `batlab diagnose` object (docs/contract.md) plus extra keys."""
        ref = self.reference
        modes = [{"measured_hz": float(f), "nominal_hz": float(n), "extended_hz": float(e),
                  "mac": float(m)}
                 for f, n, e, m in zip(self.measured_hz, self.nominal.model_hz,
                                       self.extended.model_hz, self.extended.mac, strict=True)]
        causes = []
        for s in self.causes:
            value, std = self.cause_value(s.name)
            causes.append({"name": s.name, "gain_pct": s.gain_pct, "value": value,
                           "uncertainty": std, "rms_before_pct": s.rms_before_pct,
                           "rms_after_pct": s.rms_after_pct})
        return {
            "modes": modes,
            "rms_error_pct": {"nominal": self.nominal.rms_pct, "extended": self.extended.rms_pct},
            "causes": causes,
            "calibrated": {"E_psi": ref.E_pa / PSI_TO_PA, "E_over_G": ref.e_over_g,
                           "weight_density_lbf_in3": ref.rho_kg_m3 / LBF_IN3_TO_KG_M3,
                           "sensor_mass_g": 1e3 * ref.sensor_mass_kg,
                           "shear_coefficient": ref.shear_coefficient,
                           **({"E_over_G_plane2": ref.e_over_g_plane2,
                               "tap_angle_deg": ref.tap_angle_deg}
                              if ref.e_over_g_plane2 is not None else {})},
            "not_named": [{"name": s.name, "gain_pct": s.gain_pct,
                           "in_reference": s.role == "calibration"}
                          for s in self.steps if not s.named],
            "min_gain_pct": self.min_gain_pct,
            "unpaired_hz": [float(f) for f in self.unpaired_hz],
            "warnings": list(self.warnings),
            "reference": ref.to_dict(),
            **({"sensor_mass_estimate": self.sensor.to_json_dict()} if self.sensor else {}),
        }


def observations(
    setup: Setup, measured: MeasuredModes, suspension_hz, min_mac: float,
    max_split: float = 0.12,
) -> tuple[Observations, np.ndarray, np.ndarray, list[str]]:
    """Pair measured modes with the nominal model's.

    One-to-one pairing by MAC first (or in frequency order when the shapes are unreliable:
    ``pairing_check``); with a MAC pairing, a measured mode left over whose shape matches an
    already paired model mode (MAC >= min_mac) within ``max_split`` in frequency of its
    partner is the other bending plane's member of that pair (a split pair). Each mode's
    plane, and whether a mode seen once holds both planes, by
    ``updating.diagnose.plane_pairs.plane_codes``.

    Returns
    -------
    tuple
        (observations, measured index, unpaired, pairing notes).
    """
    m = measured.freq_hz.size
    nominal = modal_sensitivities(setup, frozenset(), start_state(setup, suspension_hz), m + 4)
    meas_idx, model_idx, pair_macs = pair_modes(measured.shapes, nominal.shapes, min_mac=min_mac)
    meas_idx, model_idx, notes = checked_pairing(measured.freq_hz, measured.x_m.size, meas_idx,
                                                 model_idx, pair_macs, nominal.shapes.shape[1])
    if meas_idx.size == 0:
        raise ValueError("no measured mode matches a model mode (MAC below "
                         f"{min_mac}): check the test points and the profile")
    partner = dict(zip(model_idx.tolist(), meas_idx.tolist(), strict=True))
    macs = mac(measured.shapes, nominal.shapes)
    extra_meas, extra_model = [], []
    leftover = np.setdiff1d(np.arange(m), meas_idx) if not notes else np.zeros(0, int)
    for j in leftover:  # split pairs need trustworthy shapes
        for r in np.argsort(-macs[j]):
            if macs[j, r] < min_mac:
                break
            i = partner.get(int(r))
            if (i is not None and int(r) not in extra_model
                    and abs(measured.freq_hz[j] / measured.freq_hz[i] - 1) < max_split):
                extra_meas.append(int(j))
                extra_model.append(int(r))
                break
    meas_idx = np.concatenate([meas_idx, np.array(extra_meas, dtype=int)])
    model_idx = np.concatenate([model_idx, np.array(extra_model, dtype=int)])
    order = np.argsort(measured.freq_hz[meas_idx])
    meas_idx, model_idx = meas_idx[order], model_idx[order]
    f = measured.freq_hz[meas_idx]
    y = measured.shapes[:, meas_idx]
    norm = np.linalg.norm(y, axis=0)
    code = plane_codes(f, norm, model_idx, np.linalg.norm(nominal.shapes, axis=0))
    combined = y.copy()
    for one in np.flatnonzero((code == PLANE_1) & (norm > 0)):
        two = np.flatnonzero((model_idx == model_idx[one]) & (code == PLANE_2))[0]
        combined[:, one] = y[:, one] * np.hypot(norm[one], norm[two]) / norm[one]
    sigma_f = 5e-4
    if measured.freq_std_hz is not None and np.all(np.isfinite(measured.freq_std_hz)):
        sigma_f = max(1e-4, float(np.median(measured.freq_std_hz[meas_idx] / f)))
    susp = np.sort(np.asarray([] if suspension_hz is None else suspension_hz, dtype=float))
    ml, sigma_ml = measured_mass_line(measured)
    obs = Observations(f, y, model_idx, sigma_f, suspension_hz=susp[susp > 0][:2], code=code,
                       combined=combined, mass_line=ml, sigma_ml=sigma_ml)
    unpaired = np.setdiff1d(np.arange(m), meas_idx)
    return obs, meas_idx, measured.freq_hz[unpaired], notes


ML_SIGMA_FLOOR = 1e-4  # of the mass line's largest value: noise-free data
ML_SENSOR_MAX_KG = 0.015
"""The heaviest accelerometer (with cable and mount) a bat test uses (bat tests use 1-10 g)."""
ML_MISMATCH_REL = 0.03
"""How far the measured driving-point mass line may lie outside what the profile at the scale
weight with a 0-15 g accelerometer gives: ~10 g at the barrel end, or a 3 % calibration slip."""


def checked_mass_line(setup: Setup, obs: Observations) -> tuple[Observations, list[str]]:
    """Set the test's mass line aside (and say why) when no accelerometer explains it.

    Set aside when no accelerometer of 0 to ``ML_SENSOR_MAX_KG`` on the bat of this profile
    and scale weight explains its value at the driving point within ``ML_MISMATCH_REL``: FRFs
    off in calibration (sensitivity, units) or without the rigid body's response. Fitted
    anyway, such a mass line would put the accelerometer at a bound and pull E with it.
    Without a scale weight nothing is checked.
    """
    if obs.mass_line is None or setup.weight_kg is None:
        return obs, []
    d = int(np.argmin(np.abs(setup.points_m - setup.sensor_x_m)))
    active = frozenset({"density", "sensor_mass"})
    state = start_state(setup)
    g = [rigid_flexibility(setup, active, replace(state, sensor_mass_kg=m))[0][d]
         for m in (ML_SENSOR_MAX_KG, 0.0)]  # heavier sensor: smaller flexibility
    lo, hi = g[0] * (1 - ML_MISMATCH_REL), g[1] * (1 + ML_MISMATCH_REL)
    measured = float(obs.mass_line[d])
    if lo <= measured <= hi:
        return obs, []
    return replace(obs, mass_line=None), [
        f"mass line not used: {measured:.4g} 1/kg at the driving point, where the bat of this "
        f"profile and scale weight with a 0-{1e3 * ML_SENSOR_MAX_KG:g} g accelerometer gives "
        f"{g[0]:.4g}-{g[1]:.4g} 1/kg; check the FRFs' calibration (sensitivity, units) -- "
        "the accelerometer's mass then rests on the mode shapes' scale alone"]


def measured_mass_line(measured: MeasuredModes) -> tuple[np.ndarray | None, float]:
    """Return the test's mass line at the points and its standard uncertainty per point, 1/kg.

    The driving point's row of the rigid-body flexibility is a straight line in x (ema.shapes
    .mass_line); its uncertainty is the scatter about the least-squares line, sqrt(SSR /
    (n - 2)), at least ``ML_SIGMA_FLOOR`` of its largest value. None with fewer than 4
    points or no (or a non-finite) mass line.
    """
    a = measured.mass_line
    if a is None or np.size(a) != measured.x_m.size or measured.x_m.size < 4:
        return None, 1.0
    a = np.asarray(a, dtype=float)
    if not np.all(np.isfinite(a)) or not np.any(a):
        return None, 1.0
    x = np.asarray(measured.x_m, dtype=float)
    line = np.polyval(np.polyfit(x, a, 1), x)
    sigma = float(np.sqrt(np.sum((a - line) ** 2) / (a.size - 2)))
    return a, max(sigma, ML_SIGMA_FLOOR * float(np.abs(a).max()))


def start_state(setup: Setup, suspension_hz=None) -> State:
    """Return the starting values of a fit.

    Handbook wood, typical wood E/G, a 1 g sensor, bungees from the lowest suspension mode
    (bounce of the whole mass on two springs) or 100 N/m.
    """
    rho = setup.rho_from_weight or setup.handbook.rho_kg_m3
    k = 100.0
    if suspension_hz is not None and len(suspension_hz) and setup.weight_kg:
        k = float((2 * np.pi * np.min(suspension_hz)) ** 2 * setup.weight_kg / 2)
    return State(setup.handbook.E_pa, rho, 10.0, 1e-3, k)


def chi2_drop(before: DiagnosisFit, after: DiagnosisFit, sigma_f: float,
              frequencies_only: bool) -> float:
    """Drop of the chi-square: frequencies only, or frequencies and shapes."""
    if frequencies_only:
        return (before.ssr_freq - after.ssr_freq) / sigma_f**2
    return before.chi2(sigma_f) - after.chi2(sigma_f)


def forward_select(
    setup: Setup, obs: Observations, current: DiagnosisFit, remaining: list[str], role: str,
    accept, key, reweight=None,
) -> tuple[list[Step], DiagnosisFit, list[Step], Observations]:
    """Greedy forward selection: add the extension with the largest ``key`` while ``accept``.

    ``reweight(fit, obs) -> obs`` (optional) re-estimates the residual weights from the fit
    after each accepted step (the current fit is then refitted with them).
    Returns (accepted steps, the fit with them, the trials of the round that stopped, obs).
    """
    steps: list[Step] = []
    while remaining:
        if reweight is not None:
            obs = reweight(current, obs)
            current = fit_model(setup, current.active, obs, current.state)
        trials = []
        for c in remaining:
            active = current.active | {c}
            fit = fit_model(setup, active, obs, current.state)
            new_p = max(1, len(free_parameters(active, setup)) - len(current.names))
            trials.append(Step(c, current.rms_pct, fit.rms_pct,
                               chi2_drop(current, fit, obs.sigma_f, True),
                               chi2_drop(current, fit, obs.sigma_f, False), new_p, role, fit))
        best = max(trials, key=key)
        if not accept(best):
            return steps, current, sorted(trials, key=key, reverse=True), obs
        steps.append(best)
        current = best.fit
        remaining.remove(best.name)
    return steps, current, [], obs


def backward_check(
    setup: Setup, obs: Observations, path: list[Step], final: DiagnosisFit, nameable, facts,
) -> tuple[list[Step], DiagnosisFit, list[Step]]:
    """Re-test each named cause, smallest gain first, by removing it from the final model.

    What was measured, ``facts``, stays in the model.
    """
    dropped: list[Step] = []
    for step in sorted((s for s in path if s.named), key=lambda s: s.gain_pct):
        without = fit_model(setup, final.active - {step.name}, obs, final.state)
        back = Step(step.name, without.rms_pct, final.rms_pct,
                    chi2_drop(without, final, obs.sigma_f, True),
                    chi2_drop(without, final, obs.sigma_f, False), step.new_params, "", final)
        if nameable(back):
            continue
        if step.name in facts or back.chi2_drop >= 2 * back.new_params:
            path = [replace(s, role="calibration") if s is step else s for s in path]
        else:
            path = [s for s in path if s is not step]
            dropped.append(step)
            final = without
    return path, final, dropped


PARAMETER_LABELS = {"ln_E": "E", "ln_rho": "density", "ln_e_over_g": "E/G",
                    "sensor_g": "sensor mass", "bungee_kn_per_m": "bungee stiffness",
                    "ln_g_ratio": "the second plane's E/G", "theta": "the tapping angle"}
# relative (ln parameters), grams, kN/m, radians: above this standard uncertainty a parameter
# is reported as poorly identified
POOR = {"ln_E": 0.01, "ln_rho": 0.02, "ln_e_over_g": 0.05, "sensor_g": 0.5,
        "bungee_kn_per_m": 0.1, "ln_g_ratio": 0.05, "theta": 0.1}


def mass_line_limits(setup: Setup, obs: Observations, final: DiagnosisFit,
                     set_aside: list[str]) -> list[str]:
    """Say what the mass line establishes and what it cannot.

    Its fit at the driving point, and the accelerometer mass that a 1 % error of the FRFs'
    calibration (sensitivity) would move, a systematic error no stated uncertainty holds, and
    what a billet's unknown density gradient moves (``sensor.billet_spread``: in the mass
    line's estimate, ``sensor_mass_estimate``, not in the calibrated model's). Without one:
    why (``set_aside``, from ``checked_mass_line``, or that the test gave none).
    """
    if obs.mass_line is None:
        return set_aside or [
            "the test gave no mass line (no driving point, or the fitted band reaches below "
            "the suspension without two suspension modes): the accelerometer's mass rests on "
            "the mode shapes' scale alone"]
    g, dg = rigid_flexibility(setup, final.active | {"sensor_mass"}, final.state,
                              ("sensor_g",))
    d = int(np.argmin(np.abs(setup.points_m - setup.sensor_x_m)))
    per_pct = 0.01 * g[d] / max(abs(dg[0, d]), 1e-300)
    sensor = ""
    if "sensor_g" in final.names:
        sensor = (f"; calibrated accelerometer {1e3 * final.state.sensor_mass_kg:.2f} +- "
                  f"{final.std('sensor_g'):.2f} g")
    return [f"mass line at the driving point: measured {obs.mass_line[d]:.4g} 1/kg, model "
            f"{final.mass_line[d]:.4g} 1/kg (+-{obs.sigma_ml:.2g} per point){sensor}. The "
            "mass line fixes the accelerometer's mass independently of E, but a 1 % error of "
            f"the FRFs' calibration (sensitivity) moves it by about {per_pct:.1f} g (in no "
            "stated uncertainty); a density gradient along the billet, which the profile "
            f"cannot show, moves it by about {1e3 * billet_spread(setup) / g[d]:.1f} g "
            "(in the mass line's uncertainty below, not in the calibrated model's)"]


def data_sheet_check(setup: Setup, obs: Observations, final: DiagnosisFit) -> list[str]:
    """Check whether the data agree with meta.json's accelerometer_mass_g.

    The calibrated model refitted without it (sensor mass free) against the data sheet, within
    2.5 combined standard uncertainties.
    """
    if obs.sensor_prior_g is None:
        return []
    free = fit_model(setup, final.active | {"sensor_mass"}, replace(obs, sensor_prior_g=None),
                     final.state)
    m, s = 1e3 * free.state.sensor_mass_kg, free.std("sensor_g")
    z = (m - obs.sensor_prior_g) / np.hypot(s, obs.sigma_prior_g)
    verdict = ("consistent" if abs(z) <= 2.5 else
               "they disagree: check the accelerometer (and its cable) mass, its position "
               "and the FRFs' calibration")
    return [f"accelerometer: data sheet {obs.sensor_prior_g:.2f} +- {obs.sigma_prior_g:.1f} g "
            f"(meta.json accelerometer_mass_g, used as a prior); the data alone give "
            f"{m:.2f} +- {s:.2f} g: {verdict}"]


def limits(obs: Observations, final: DiagnosisFit, solid_tried: bool,
           setup: Setup, mass_line_set_aside: list[str]) -> tuple[str, ...]:
    """Say what the calibrated model could not establish (Diagnosis.warnings).

    ``mass_line_set_aside``: why the test's mass line was not used (``checked_mass_line``).
    """
    out = []
    code = obs.codes
    if obs.n_split == 0:
        out.append("each bending mode was seen once: the two bending planes are not resolved "
                   "(tapped in a grain plane, or a split below the frequency resolution); "
                   "two_planes not assessed")
    elif np.any(code == SEEN_ONCE):
        hz = ", ".join(f"{f:.0f}" for f in obs.freq_hz[code == SEEN_ONCE])
        out.append(f"modes at {hz} Hz were seen once (the other bending plane's member was "
                   "not found); they are compared with the first plane's model at full "
                   "amplitude")
    if obs.n_split and np.any(code == BOTH_IN_ONE):
        hz = ", ".join(f"{f:.0f}" for f in obs.freq_hz[code == BOTH_IN_ONE])
        out.append(f"modes at {hz} Hz hold both bending planes' members in one peak (split "
                   "below its width, the full pair's amplitude): each is compared with the "
                   "two planes' mix (updating.diagnose.planes)")
    for name, v in zip(final.names, final.x, strict=True):
        lo, hi = BOUNDS[name]
        label = PARAMETER_LABELS[name]
        if min(v - lo, hi - v) < 1e-4 * (hi - lo):
            out.append(f"{label} ended at its bound ({v:.4g} in fit units): not identified "
                       "by the data, fixed by the bound")
        elif final.std(name) > POOR[name]:
            out.append(f"{label} is poorly identified (standard uncertainty {final.std(name):.3g}"
                       f" in fit units, above {POOR[name]})")
    if "sensor_mass" not in final.active:
        out.append("no accelerometer mass in the calibrated model: the data did not show one. "
                   "A mass near a free end lowers every mode by about the same fraction, as a "
                   "lower E does, so frequencies alone cannot separate them; only the mass "
                   "line and the absolute scale of the mass-normalised shapes can. If an "
                   "accelerometer was mounted, E is low by about its share")
    out += mass_line_limits(setup, obs, final, mass_line_set_aside)
    if "ln_E" in final.names and "ln_e_over_g" in final.names:
        i, j = final.names.index("ln_E"), final.names.index("ln_e_over_g")
        c = final.cov[i, j] / np.sqrt(max(final.cov[i, i] * final.cov[j, j], 1e-300))
        if abs(c) > 0.95:
            out.append(f"E and E/G are strongly correlated in the fit (r = {c:.2f}): an error "
                       "the model family cannot represent moves both")
    floor = 100 * obs.sigma_f
    if final.rms_pct > 3 * floor:
        hint = ("" if solid_tried else
                " (batlab diagnose --solid measures what a 1D beam cannot represent)")
        out.append(f"residual floor: the calibrated model misses the frequencies by "
                   f"{final.rms_pct:.3f} % RMS, {final.rms_pct / floor:.0f} x their "
                   f"uncertainty ({floor:.3f} %): the model family lacks something{hint}")
    return tuple(out)


def diagnose(
    profile: Profile, meta: BatMeta, measured: MeasuredModes, suspension_hz=None,
    min_gain_pct: float = MIN_GAIN_PCT, min_mac: float = 0.5,
    fine_element_m: float = FINE_ELEMENT_IN * IN_TO_M, shape_sigma_floor: float = 0.002,
    solid_corrections: np.ndarray | None = None,
) -> Diagnosis:
    """Diagnose a baseline test against the nominal model and calibrate the bat's reference.

    Parameters
    ----------
    profile : Profile
        The caliper profile.
    meta : BatMeta
        meta.json (handbook wood, scale weight).
    measured : MeasuredModes
        The baseline's elastic modes (mass-normalised shapes at the test points).
    suspension_hz
        Measured rigid-body (suspension) frequencies below 20 Hz, or None.
    min_gain_pct : float
        An extension must lower the RMS frequency error by this much (pp) to be named a cause.
    min_mac : float
        Pairing threshold.
    fine_element_m : float
        Element length of the 'geometry' extension.
    shape_sigma_floor : float
        Least relative uncertainty of a measured shape entry.
    solid_corrections : np.ndarray | None
        Per-mode corrections c_r of the 1D beam against a 3D solid (updating.solid.compare);
        'beam_theory' is tried only with them.
    """
    if measured.shapes.shape[0] != measured.x_m.size:
        raise ValueError("measured shapes do not match the number of test points")
    if np.any(measured.x_m < -1e-9) or np.any(measured.x_m > profile.length_m + 1e-9):
        raise ValueError("a test point lies outside the bat's profile")
    setup = Setup(profile, meta.material, meta.weight_kg, np.asarray(measured.x_m, dtype=float),
                  float(measured.sensor_x_m), fine_element_m,
                  None if solid_corrections is None else np.asarray(solid_corrections, float))
    obs, meas_idx, unpaired, warnings = observations(setup, measured, suspension_hz, min_mac)
    obs, ml_set_aside = checked_mass_line(setup, obs)
    if meta.accelerometer_mass_kg is not None:  # the data sheet's mass: a prior
        obs = replace(obs, sensor_prior_g=1e3 * meta.accelerometer_mass_kg)
    nominal = fit_model(setup, frozenset(), obs, start_state(setup, suspension_hz))
    crit = chi2_ppf(CONFIDENCE, np.arange(8))

    def nameable(s: Step) -> bool:
        return s.gain_pct >= min_gain_pct and s.chi2_drop_freq >= crit[s.new_params]

    remaining = [c for c in CAUSES if not (c == "density" and meta.weight_kg is None
                                           and not np.any(measured.shapes))
                 and not (c == "two_planes" and obs.n_split == 0)
                 and not (c == "beam_theory" and setup.solid_corrections is None)]
    # 1. causes: extensions that lower the frequency error measurably and significantly
    named, current, _, _ = forward_select(setup, obs, nominal, remaining, "cause",
                                          accept=nameable, key=lambda s: s.gain_pct)
    # 2. what was measured rather than fitted: the scale weight, the suspension modes
    facts = ["density"] if meta.weight_kg is not None else []
    if obs.suspension_hz.size:
        facts.append("suspension")
    measured_steps = []
    for c in (c for c in facts if c in remaining):
        fit = fit_model(setup, current.active | {c}, obs, current.state)
        new_p = max(1, len(fit.names) - len(current.names))
        measured_steps.append(Step(c, current.rms_pct, fit.rms_pct,
                                   chi2_drop(current, fit, obs.sigma_f, True),
                                   chi2_drop(current, fit, obs.sigma_f, False), new_p,
                                   "calibration", fit))
        current = fit
        remaining.remove(c)
    # 3. calibration: further extensions that improve the fit of frequencies and shapes by
    # more than they cost (Akaike: chi-square drop above 2 per parameter); the shape-noise
    # level is re-estimated from the current model before each round
    support, final, rejected, obs = forward_select(
        setup, obs, current, remaining, "calibration",
        accept=lambda s: s.chi2_drop >= 2 * s.new_params, key=lambda s: s.chi2_drop,
        reweight=lambda fit, o: replace(o, sigma_s=shape_sigma(fit, o, shape_sigma_floor)))
    # an extension in the calibrated model is named whenever its measured gain qualifies
    path = named + [replace(s, role="cause") if nameable(s) else s
                    for s in measured_steps + support]
    # 5. backward check: a cause the calibrated model does not need (removing it costs less
    # than the naming threshold, an artefact of the greedy order) is not named; it leaves the
    # model too unless the shapes and frequencies still support it (Akaike)
    path, final, dropped = backward_check(setup, obs, path, final, nameable, facts)
    rejected = [replace(s, role="rejected") for s in dropped + rejected]
    reference = reference_of(setup, final.active, final.state)
    warnings += pairing_warnings(final, obs.model_index, by_mac=not warnings)
    refuse = refuse_causes(warnings)
    warnings += limits(obs, final, setup.solid_corrections is not None, setup, ml_set_aside)
    warnings += data_sheet_check(setup, obs, final)
    sensor = estimate_sensor_mass(setup, obs, final)
    if np.isfinite(sensor.combined.std_kg):
        warnings.append(sensor_note(sensor, final))
    if refuse:  # 6. no cause is named from a pairing that cannot be trusted
        warnings.append("causes not named: the pairing or the calibration cannot be trusted")
        path = [replace(s, role="calibration") if s.named else s for s in path]
    return Diagnosis(obs.freq_hz, meas_idx, obs.model_index, nominal, final,
                     tuple(path + rejected), unpaired, min_gain_pct, reference,
                     fine_element_m, tuple(warnings), obs.n_split,
                     int(np.sum(obs.codes == BOTH_IN_ONE)), sensor)
