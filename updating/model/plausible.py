"""What a wooden bat can be: the lab's inputs checked before any fitting.

Each check returns None or a one-line message naming the file and the key. A value off by a
common unit factor gets its likely cause, e.g. ``weight_lb 873.6 looks like grams: 1.926 lb?``.
After the baseline's fit and calibration, ``check_baseline`` says in a few lines why it cannot
be this bat's (another bat's, or one of the same length but heavier: ``check_mass_line``).
Handbook values: Wood Handbook (FPL-GTR-282, 2021), table 5-3a, 12 % moisture; weight density
= SG * 0.0361 lbf/in^3.
"""

from __future__ import annotations

import re

import numpy as np

from updating.model.mass_properties import rigid_mass_line, solid_mass_properties, with_point_mass
from updating.model.units import IN_TO_M, LB_TO_KG

LENGTH_IN = (24.0, 42.0)
DIAMETER_IN = (0.5, 2.75)
WEIGHT_LB = (15.0 / 16.0, 50.0 / 16.0)
NOMINAL_FACTOR = 2.0
"""A species' nominal E and weight density must be within this factor of the handbook's."""
WATER_LBF_IN3 = 0.0361
HANDBOOK = {  # species keyword: (E psi, specific gravity)
    "ash": (1.74e6, 0.60),  # white ash
    "yellow birch": (2.02e6, 0.62),
    "birch": (1.60e6, 0.55),  # paper (white) birch
    "maple": (1.83e6, 0.63),  # sugar (hard) maple
}
_LENGTH_SLIPS = (("millimetres", 25.4), ("centimetres", 2.54), ("metres", 0.0254))
_WEIGHT_SLIPS = (("grams", 453.59237), ("ounces", 16.0), ("kilograms", 0.45359237))
_E_SLIPS = (("GPa", 6.894757e-3), ("MPa", 6.894757), ("ksi", 1e-3), ("Mpsi", 1e-6),
            ("Pa", 6894.757))
_DENSITY_SLIPS = (("a specific gravity", 1 / WATER_LBF_IN3), ("kg/m^3", 27679.9),
                  ("lb/ft^3", 1728.0))


def handbook_range(species: str) -> tuple[tuple[float, float], tuple[float, float]]:
    """Return the accepted (E psi, weight density lbf/in^3) ranges for a species.

    The species' handbook values times and divided by ``NOMINAL_FACTOR``; a species not in
    ``HANDBOOK`` (matched by its first keyword found in the name) gets the range over all.

    Parameters
    ----------
    species : str
        The species as meta.json names it ("white ash", "paper birch", "hard maple", ...).

    Returns
    -------
    e_psi : tuple of float
        Lowest and highest nominal modulus, psi.
    density_lbf_in3 : tuple of float
        Lowest and highest nominal weight density, lbf/in^3.
    """
    name = species.lower()
    known = [v for k, v in HANDBOOK.items() if k in name][:1] or list(HANDBOOK.values())
    e = np.array([v[0] for v in known])
    wd = np.array([v[1] for v in known]) * WATER_LBF_IN3
    f = NOMINAL_FACTOR
    return (e.min() / f, e.max() * f), (wd.min() / f, wd.max() * f)


def _out_of_range(value: float, limits: tuple[float, float], what: str, unit: str,
                  slips: tuple[tuple[str, float], ...]) -> str | None:
    """Return None when ``value`` is within ``limits``, else a message with its likely slip."""
    lo, hi = limits
    if lo <= value <= hi:
        return None
    for name, per_unit in slips:
        if lo <= value / per_unit <= hi:
            return f"{what} {value:g} looks like {name}: {value / per_unit:.4g} {unit}?"
    return f"{what} {value:g} is outside {lo:.4g}-{hi:.4g} {unit} for a wooden bat"


def check_profile(x_m: np.ndarray, diameter_m: np.ndarray, label: str) -> str | None:
    """Check a profile's length and diameters against a wooden bat's.

    Parameters
    ----------
    x_m, diameter_m : ndarray
        The stations from the knob end and the outer diameters there, m.
    label : str
        The file, for the message.

    Returns
    -------
    str or None
        The message, None when plausible.
    """
    length_in = float(x_m[-1] - x_m[0]) / IN_TO_M
    lo, hi = LENGTH_IN
    if not lo <= length_in <= hi:
        slip = next((n for n, k in _LENGTH_SLIPS if lo <= length_in / k <= hi), None)
        cause = f": {slip}?" if slip else f", not {lo:g}-{hi:g} in"
        return f"{label}: the bat is {length_in:.4g} in long{cause}"
    return check_diameters(diameter_m, label)


def check_diameters(diameter_m: np.ndarray, label: str) -> str | None:
    """Check a profile's diameters against a wooden bat's, naming a unit slip (mm, cm).

    Parameters
    ----------
    diameter_m : ndarray
        The outer diameters read, m.
    label : str
        The file, for the message.

    Returns
    -------
    str or None
        The message, None when plausible.
    """
    d_in = np.asarray(diameter_m, dtype=float) / IN_TO_M
    lo, hi = DIAMETER_IN
    if d_in.min() < lo or d_in.max() > hi:
        bad = d_in.max() if d_in.max() > hi else d_in.min()
        slip = next((n for n, k in _LENGTH_SLIPS if lo <= d_in.min() / k
                     and d_in.max() / k <= hi), None)
        cause = f": {slip}?" if slip else " for a wooden bat"
        return f"{label}: diameter {bad:.4g} in is outside {lo:g}-{hi:g} in{cause}"
    return None


SURVEY_END_TOL_IN = 0.25
"""How far a re-test survey's stations may lie outside the registered bat (a caliper's jaws
on the knob's or the barrel end's edge)."""
SURVEY_LOSS_MAX_IN = 0.25
"""Largest diameter a re-test may have lost at a station and still be this bat: shaving takes
at most 0.1 in and a groove's ring 0.12 in (docs/inspection.md); twice that."""
SURVEY_GAIN_MAX_IN = 0.15
"""Largest diameter a re-test may have gained: grip tape wound over itself, a coat (0.02-0.06
in); more is another bat, or the profile read from the other end."""
SURVEY_ODD_SHARE = 0.1
"""Share of stations beyond those limits that makes a survey another bat's (or swapped)."""


def _odd_share(x_m: np.ndarray, d_m: np.ndarray, reg_x_m: np.ndarray,
               reg_d_m: np.ndarray) -> float:
    """Share of stations whose diameter differs from the registered one beyond shaving sizes."""
    delta_in = (d_m - np.interp(x_m, reg_x_m, reg_d_m)) / IN_TO_M
    return float(np.mean((delta_in < -SURVEY_LOSS_MAX_IN) | (delta_in > SURVEY_GAIN_MAX_IN)))


def check_survey(x_m: np.ndarray, diameter_m: np.ndarray, reg_x_m: np.ndarray,
                 reg_diameter_m: np.ndarray, label: str) -> str | None:
    """Check a re-test's caliper survey against the registered profile: units, the same bat.

    Diameters in mm or cm, stations past the registered bat's ends (mm, cm named), a
    survey read from the barrel end (it matches the registered profile reversed), or
    diameters that differ beyond what shaving, grooves and a grip can make at more than
    ``SURVEY_ODD_SHARE`` of the stations (another bat).

    Parameters
    ----------
    x_m, diameter_m : ndarray
        The survey's stations and their mean readings, m.
    reg_x_m, reg_diameter_m : ndarray
        The registered profile's stations and diameters, m.
    label : str
        The file, for the message.

    Returns
    -------
    str or None
        The message, None when plausible.
    """
    message = check_diameters(diameter_m, label)
    if message:
        return message
    length_in = float(reg_x_m[-1] - reg_x_m[0]) / IN_TO_M
    x_in = (np.asarray(x_m, dtype=float) - reg_x_m[0]) / IN_TO_M
    tol = SURVEY_END_TOL_IN
    if x_in.min() < -tol or x_in.max() > length_in + tol:
        slip = next((n for n, k in _LENGTH_SLIPS  # the slip that ends it at the barrel end
                     if x_in.min() / k >= -tol and abs(x_in.max() / k - length_in) <= 1.0),
                    None)
        cause = f": {slip}?" if slip else ": another bat's profile?"
        return (f"{label}: stations run from {x_in.min():.4g} to {x_in.max():.4g} in, "
                f"outside the registered bat (0-{length_in:.4g} in){cause}")
    odd = _odd_share(x_m, diameter_m, reg_x_m, reg_diameter_m)
    if odd <= SURVEY_ODD_SHARE:
        return None
    flipped = reg_x_m[0] + reg_x_m[-1] - np.asarray(x_m, dtype=float)
    order = np.argsort(flipped, kind="stable")
    if _odd_share(flipped[order], np.asarray(diameter_m)[order], reg_x_m,
                  reg_diameter_m) <= SURVEY_ODD_SHARE:
        return (f"{label}: it matches the registered profile read from the barrel end: knob "
                "and barrel swapped (x must run from the knob end)?")
    return (f"{label}: {100 * odd:.0f} % of its stations differ from the registered profile "
            f"by more than shaving ({SURVEY_LOSS_MAX_IN:g} in) or a grip "
            f"({SURVEY_GAIN_MAX_IN:g} in) can: another bat's profile?")


def check_meta(meta: dict, label: str) -> str | None:
    """Check meta.json's weight and the species' nominal values against a wooden bat's.

    Parameters
    ----------
    meta : dict
        meta.json as read (``weight_lb``, ``nominal_E_psi``,
        ``nominal_weight_density_lbf_in3``, ``species``).
    label : str
        The file, for the message.

    Returns
    -------
    str or None
        The message, None when plausible.
    """
    e_range, wd_range = handbook_range(str(meta.get("species", "")))
    checks = [("nominal_E_psi", e_range, "psi", _E_SLIPS),
              ("nominal_weight_density_lbf_in3", wd_range, "lbf/in^3", _DENSITY_SLIPS)]
    if meta.get("weight_lb") is not None:
        checks.insert(0, ("weight_lb", WEIGHT_LB, "lb", _WEIGHT_SLIPS))
    for key, limits, unit, slips in checks:
        value = meta.get(key)
        if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
            continue  # missing or not a number: lab_input.read_meta names it
        message = _out_of_range(float(value), limits, key, unit, slips)
        if message:
            return f"{label}: {message}"
    return None


def check_points(points_m: np.ndarray, x_m: np.ndarray, tol_m: float, label: str) -> str | None:
    """Check that no test point lies before the knob end.

    Points past the barrel end are reported by the reader with the bat's length.

    Parameters
    ----------
    points_m : ndarray
        The impact points from the knob end, m.
    x_m : ndarray
        The profile's stations, m.
    tol_m : float
        The tolerance, m.
    label : str
        The file, for the message.

    Returns
    -------
    str or None
        The message, None when all points are at or after the knob end.
    """
    if points_m.size and points_m.min() < x_m[0] - tol_m:
        return (f"{label}: points_in has {points_m.min() / IN_TO_M:.4g} in, before the "
                "knob end")
    return None


MAX_BASELINE_RMS_PCT = 2.0
"""Largest RMS frequency miss of a bat's own calibrated baseline: the simulated fleet's are
under 0.3 %, another bat's (profile unlike this one) several %."""
_AT_LIMIT = re.compile(r"parameter (\w+) = (\S+) is at its (upper|lower) bound")
_LAB_NAMES = {"E": "the modulus (Pa)", "rho": "the density (kg/m^3)", "e_over_g": "E/G",
              "sensor_g": "the accelerometer's mass (g)",
              "bungee_kn_per_m": "the bungees' stiffness (kN/m)",
              "g_ratio": "the two grain planes' stiffness ratio", "theta": "the grain angle"}
SENSOR_MAX_KG = 0.015
"""Heaviest accelerometer (with its cable) a lab puts on a bat, kg."""
MASS_LINE_REL = 0.05
"""Allowed miss of the driving-point mass line beyond the accelerometer's range: calibration
and wood density not uniform (the simulated fleet's baselines: within -1.6 % to +2.8 %)."""


def driving_point_mass_line(x_m: np.ndarray, diameter_m: np.ndarray, weight_kg: float,
                            x_drive_m: float, sensor_kg: float = 0.0) -> float:
    """Return a free bat's rigid-body flexibility at its driving point, 1/kg.

    ``mass_properties.rigid_mass_line`` at x = x_d, a(x_d) = 1/M + (x_d - x_c)^2 / I, for
    the profile's solid of revolution at uniform density weighing ``weight_kg``
    (``solid_mass_properties``) with an accelerometer of ``sensor_kg`` at the driving point.
    """
    mp = with_point_mass(solid_mass_properties(x_m, diameter_m, weight_kg), sensor_kg,
                         x_drive_m)
    return float(rigid_mass_line(mp, x_drive_m, x_drive_m))


def check_mass_line(a_drive_per_kg: float, x_m: np.ndarray, diameter_m: np.ndarray,
                    weight_kg: float, x_drive_m: float) -> str | None:
    """Check a test's driving-point mass line against the bat's profile and scale weight.

    A bat of the same length but heavier (or lighter) gives a mass line smaller (larger) in
    proportion: the accelerometer (0 to ``SENSOR_MAX_KG``) and a calibration error of
    ``MASS_LINE_REL`` are allowed.

    Parameters
    ----------
    a_drive_per_kg : float
        The measured mass line at the driving point, 1/kg.
    x_m, diameter_m : ndarray
        The profile's stations and diameters, m.
    weight_kg : float
        meta.json's weight, kg.
    x_drive_m : float
        The driving point from the knob end, m.

    Returns
    -------
    str or None
        One line (the bat's weight the mass line implies), None when plausible.
    """
    bare = driving_point_mass_line(x_m, diameter_m, weight_kg, x_drive_m)
    hi = bare * (1 + MASS_LINE_REL)
    lo = driving_point_mass_line(x_m, diameter_m, weight_kg, x_drive_m, SENSOR_MAX_KG) * (
        1 - MASS_LINE_REL)
    if lo <= a_drive_per_kg <= hi:
        return None
    implied_lb = weight_kg * bare / a_drive_per_kg / LB_TO_KG
    return (f"its mass line ({a_drive_per_kg:.4g} 1/kg at the driving point, {lo:.4g}-"
            f"{hi:.4g} expected) says the bat weighs about {implied_lb:.3g} lb, not "
            f"meta.json's weight_lb {weight_kg / LB_TO_KG:.4g}")


def check_baseline(e_psi: float, species: str, rms_pct: float, warnings, label: str,
                   serial: str, mass_line: str | None = None) -> str | None:
    """Check that a calibrated baseline can be the bat that profile.csv and meta.json describe.

    Another bat's baseline shows as a calibrated modulus outside the species' range
    (``handbook_range``), a model of this profile that misses the frequencies by more than
    ``MAX_BASELINE_RMS_PCT``, a fitted parameter held at its bound, or a driving-point mass
    line that the bat at its scale weight cannot give (``check_mass_line``).

    Parameters
    ----------
    e_psi : float
        The calibrated modulus, psi.
    species : str
        meta.json's species.
    rms_pct : float
        RMS frequency error of the calibrated model, %.
    warnings : iterable of str
        The calibration's warnings (``updating.diagnose.run.Diagnosis.warnings``).
    label : str
        The baseline file, for the message.
    serial : str
        The bat's serial, for the message.
    mass_line : str or None
        ``check_mass_line``'s message.

    Returns
    -------
    str or None
        A message of a few lines (what is wrong, what to check), None when plausible.
    """
    (e_lo, e_hi), _ = handbook_range(species)
    found = [f"the calibration could match it only with {_LAB_NAMES.get(m[1], m[1])} at its "
             f"{m[3]} limit ({m[2]})" for m in map(_AT_LIMIT.search, warnings) if m]
    if mass_line:
        found.insert(0, mass_line)
    if not e_lo <= e_psi <= e_hi:
        found.insert(0, f"its calibrated modulus {e_psi:,.0f} psi is outside "
                        f"{e_lo:,.0f}-{e_hi:,.0f} psi for {species}")
    if rms_pct > MAX_BASELINE_RMS_PCT:
        found.insert(0, f"the model of this profile misses its frequencies by {rms_pct:.2g} % "
                        f"RMS (a bat's own baseline: under {MAX_BASELINE_RMS_PCT:g} %)")
    if not found:
        return None
    return "\n".join([f"{label}: does not look like the baseline of bat {serial} as "
                      "profile.csv and meta.json describe it:", *(f"  {f}" for f in found),
                      f"  check: that {label} is bat {serial}'s test, meta.json's weight_lb "
                      "and species, profile.csv, and the FRFs' calibration (sensitivity, "
                      "units); nothing stored"])
