"""Nuisance-rich virtual bats as a lab hands them over: lab files plus the hidden truth.

``draw_case`` makes one bat: a random pro profile (caliper noise on the lab's copy), a random
species with E within +-15 % and density within +-8 % of its handbook values (meta.json gives
the handbook values), a 2-6 g accelerometer up to 0.05 in off its labelled point near the
barrel end, two bungees of 100-400 N/m; then every nuisance asked for
(``updating.simulate.nuisances``, each switchable on its own), an alteration of the re-test
(``updating.simulate.alterations``) or none, and optionally a data-integrity slip
(``updating.simulate.integrity``). ``write_case`` writes the contract's files: profile.csv,
meta.json, baseline.uff, retest.uff and retest.json (weight_lb, accelerometer_mass_g,
temperature_c, tested_on), and on request the re-test's caliper profile, retest_profile.csv
(``updating.simulate.calipers``; ``write_fleet_retest`` writes a fleet folder's
SERIAL.uff, SERIAL.json and SERIAL.profile.csv). ``FieldCase.truth`` is the JSON-able hidden
truth, with the answer expected of the inspection: "altered" for an altered bat,
"not_altered" for a clean one, "inconclusive" for a data-integrity case (never "altered").

A scale reads a bat's weight to 0.002 lb (1 sigma) and a balance point to 0.03 in; the truth
records both readings at registration and at the re-test, for the lab's own methods.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np

from ema.io.frf_io import write_test
from updating.model.calipers import write_survey_csv
from updating.model.mass_properties import mass_properties
from updating.model.material import Material, material_from_imperial
from updating.model.profile import Profile, write_profile_csv
from updating.model.units import IN_TO_M, LB_TO_KG
from updating.simulate import nuisances as nz
from updating.simulate.alterations import KINDS, Alteration, AlterationKind, draw_alteration
from updating.simulate.calipers import retest_survey
from updating.simulate.fleet import SPECIES, pro_profile, random_wood
from updating.simulate.integrity import INTEGRITY, Integrity, corrupt
from updating.simulate.rulebook import RULEBOOK_KINDS, RulebookKind, draw_change
from updating.simulate.virtual_bat import VirtualBat, simulate_test

FieldKind = Literal["none", AlterationKind]
"""The re-test of a field case: unaltered ("none") or one of ``alterations.KINDS``."""

SCALE_SIGMA_LB = 0.002
BALANCE_SIGMA_IN = 0.03
NO_BARREL = (16.0, 34.0)
"""The layout of the ``no_barrel_points`` case has no impact point in this range (in) but
the end face (where its accelerometer sits)."""


@dataclass(frozen=True)
class FieldCase:
    """One bat's lab files (as objects) and the truth behind them.

    Attributes
    ----------
    profile : Profile
        The caliper profile the lab has (noisy copy of the truth's).
    meta : dict
        The content of meta.json (handbook values, registered weight, points).
    retest_meta : dict
        The content of retest.json.
    baseline, retest : VirtualBat
        The truth of the two tests (the re-test of ``other_bat`` is another bat's).
    freq_hz : np.ndarray
        The frequency lines of both tests.
    integrity : Integrity | None
        None or one of INTEGRITY (a slip applied to the re-test file).
    truth : dict
        JSON-able hidden truth (kind, expected answer, alteration, nuisances drawn, true and
        measured weights and balance points).
    """

    profile: Profile
    meta: dict
    retest_meta: dict
    baseline: VirtualBat
    retest: VirtualBat
    freq_hz: np.ndarray
    integrity: Integrity | None
    truth: dict

    @property
    def kind(self) -> FieldKind:
        """Return the re-test's alteration kind ("none" when clean)."""
        return self.truth["kind"]

    @property
    def expected(self) -> str:
        """Return the answer expected of the inspection."""
        return self.truth["expected"]

    @property
    def registration_conditions(self) -> dict:
        """Return what a lab may record at registration beside the weight.

        meta.json's optional keys: the baseline's temperature and accelerometer mass, read as
        retest.json's, and the date, room and moisture readings when the case has them
        (``meter.with_lab_records``).
        """
        t_base = self.truth["drawn"].get("temperature", {}).get("baseline_c", 21.0)
        return {"temperature_c": round(t_base, 1),
                "accelerometer_mass_g": round(1e3 * self.baseline.sensor_mass_kg, 2),
                **self.truth.get("lab_records", {}).get("registration", {})}

    @property
    def min_plug_in(self) -> float:
        """The shortest plug an alteration of this bat can have (behind a cupped end)."""
        return self.truth["drawn"].get("cup", {}).get("depth_in", 0.0) + 0.25


def scale_reading(bat: VirtualBat) -> tuple[float, float]:
    """(weight lb, balance point in from the knob) of the bare bat, without reading noise."""
    mp = mass_properties(bat.truth_model())
    return mp.mass_kg / LB_TO_KG, mp.cg_m / IN_TO_M


def bare(bat: VirtualBat) -> VirtualBat:
    """Take the bat off the rig: no accelerometer, no bungees (what the scale weighs)."""
    return replace(bat, sensor_mass_kg=0.0, bungee_k_n_per_m=0.0)


def lab_readings(rng: np.random.Generator, base: VirtualBat, retest: VirtualBat,
                 truth: dict) -> None:
    """Put the true and the scale's (noisy) weights and balance points of both tests in ``truth``.

    Keys true_weight_lb, true_balance_in and lab_readings (baseline_lb, retest_lb,
    baseline_balance_in, retest_balance_in).
    """
    w_b, cg_b = scale_reading(bare(base))
    w_r, cg_r = scale_reading(bare(retest))
    truth["true_weight_lb"] = {"baseline": w_b, "retest": w_r}
    truth["true_balance_in"] = {"baseline": cg_b, "retest": cg_r}
    truth["lab_readings"] = {k: v + s * rng.standard_normal() for k, v, s in (
        ("baseline_lb", w_b, SCALE_SIGMA_LB), ("retest_lb", w_r, SCALE_SIGMA_LB),
        ("baseline_balance_in", cg_b, BALANCE_SIGMA_IN),
        ("retest_balance_in", cg_r, BALANCE_SIGMA_IN))}


def no_barrel_points_in(length_in: float) -> np.ndarray:
    """Return a layout that cannot see the barrel, in.

    Every 2 in up to 15 in, and the end face (where the accelerometer goes).
    """
    return np.append(np.arange(1.0, NO_BARREL[0], 2.0), np.floor(100 * length_in) / 100)


def _check_request(kind: FieldKind | RulebookKind, nuisances: tuple,
                   integrity: Integrity | None) -> None:
    """Raise ValueError for an unknown nuisance, alteration kind or integrity case."""
    unknown = set(nuisances) - set(nz.NUISANCES) - set(nz.OPTIONAL_NUISANCES)
    if unknown:
        raise ValueError(f"unknown nuisance(s) {sorted(unknown)}")
    if kind != "none" and kind not in KINDS + RULEBOOK_KINDS:
        raise ValueError(f"unknown alteration kind {kind!r} "
                         f"(none, {', '.join(KINDS + RULEBOOK_KINDS)})")
    if integrity is not None and integrity not in INTEGRITY:
        raise ValueError(f"unknown integrity case {integrity!r} ({', '.join(INTEGRITY)})")


def _draw_profiles(rng: np.random.Generator) -> tuple[Profile, Profile]:
    """Draw a pro profile and the lab's caliper copy of it (0.003 in noise, 1 sigma).

    Returns
    -------
    truth_profile, lab_profile : Profile
        The bat's true profile and the one the lab measures.
    """
    truth_profile = pro_profile(rng)
    profile = Profile(truth_profile.x_m, truth_profile.diameter_m
                      + 0.003 * IN_TO_M * rng.standard_normal(truth_profile.x_m.size))
    return truth_profile, profile


def _draw_test_setup(
    rng: np.random.Generator, on: set, profile: Profile, nominal: Material,
    integrity: Integrity | None, rec: dict,
) -> tuple[np.ndarray, float, float]:
    """Draw the impact points, the band and the FRF noise of both tests (recorded in ``rec``).

    Returns
    -------
    points_in : ndarray
        The impact points (in from the knob).
    fmax_hz : float
        The top of the measured band (Hz).
    rel_noise : float
        The FRF noise relative to the FRF's RMS.
    """
    length_in = profile.length_m / IN_TO_M
    points_in = nz.lab_points_in(length_in)
    if "points" in on:
        points_in = nz.draw_points(rng, length_in)
    if "model_points" in on:
        points_in = nz.draw_model_points(rng, profile, nominal)
    if integrity == "no_barrel_points":
        points_in = no_barrel_points_in(length_in)
    rec["points"] = len(points_in)
    fmax = nz.draw_band(rng) if "band" in on else 3200.0
    rec["fmax_hz"] = fmax
    noise = nz.draw_noise(rng) if "noise" in on else 0.005
    rec["noise"] = noise
    return points_in, fmax, noise


def _draw_rig(
    rng: np.random.Generator, on: set, base: VirtualBat, rec: dict,
) -> tuple[VirtualBat, dict]:
    """Draw the accelerometer and the bungees of the baseline and their re-test changes.

    Returns
    -------
    base : VirtualBat
        ``base`` with a 2-6 g accelerometer up to 0.05 in off its label and bungees of
        100-400 N/m.
    re_changes : dict
        The re-test's changes to them (``VirtualBat`` fields), for the nuisances ``on``.
    """
    sensor_mass = rng.uniform(0.002, 0.006)
    offset = rng.uniform(-0.05, 0.05) * IN_TO_M
    bungee = rng.uniform(100.0, 400.0)
    base = replace(base, sensor_offset_m=offset, sensor_mass_kg=sensor_mass,
                   bungee_k_n_per_m=bungee)
    re_changes: dict = {}
    if "accelerometer" in on:
        m, off, rec["accelerometer"] = nz.draw_accelerometer(rng, sensor_mass, offset)
        re_changes.update(sensor_mass_kg=m, sensor_offset_m=off)
    if "bungees" in on:
        re_changes["bungee_k_n_per_m"], rec["bungees"] = nz.draw_bungees(rng, bungee)
    return base, re_changes


def _draw_wood_fields(rng: np.random.Generator, on: set, length_m: float, rec: dict):
    """Draw the wood's fields along the bat: billet, temperature, moisture, uniform drift.

    Returns
    -------
    base_field, retest_field : WoodField or None
        The combined fields of the baseline and of the re-test.
    """
    base_fields, re_fields = [], []
    if "billet" in on:
        f, rec["billet"] = nz.draw_billet(rng, length_m)
        base_fields.append(f)
        re_fields.append(f)
    if "temperature" in on:
        fb, fr, rec["temperature"] = nz.draw_temperature(rng, length_m)
        base_fields.append(fb)
        re_fields.append(fr)
    if "moisture" in on:
        f, rec["moisture"] = nz.draw_moisture(rng, length_m)
        re_fields.append(f)
    if "uniform_drift" in on:
        f, rec["uniform_drift"] = nz.draw_uniform_drift(rng, length_m)
        re_fields.append(f)
    return nz.combine(*base_fields), nz.combine(*re_fields)


def _draw_planes_and_cup(
    rng: np.random.Generator, on: set, base: VirtualBat, re_changes: dict, rec: dict,
) -> tuple[VirtualBat, float]:
    """Draw the two bending planes (E/G, grain angle) and a cupped end, as ``on`` asks.

    The re-test's grain angle goes into ``re_changes``.

    Returns
    -------
    base : VirtualBat
        The baseline with its planes and cup.
    cup_depth_in : float
        The cup's depth (in), 0 without one.
    """
    if "planes" in on:
        eg_r, eg_t, th_b, th_r, rec["planes"] = nz.draw_planes(rng)
        base = replace(base, material=replace(base.material, e_over_g=eg_r), e_over_g_t=eg_t,
                       theta_deg=th_b)
        re_changes["theta_deg"] = th_r
    cup_depth_in = 0.0
    if "cup" in on:
        cup, rec["cup"] = nz.draw_cup(rng)
        base = replace(base, cavities=(cup,))
        cup_depth_in = rec["cup"]["depth_in"]
    return base, cup_depth_in


def _lab_meta(
    serial: str, species: str, points_in: np.ndarray, retest: VirtualBat, truth: dict,
) -> tuple[dict, dict]:
    """Write down meta.json's and retest.json's content from the scale readings in ``truth``.

    Returns
    -------
    meta, retest_meta : dict
        The two files' content.
    """
    E_psi, wd = SPECIES[species]
    meas = truth["lab_readings"]
    meta = {"serial": serial, "species": species, "nominal_E_psi": E_psi,
            "nominal_weight_density_lbf_in3": round(wd, 5),
            "weight_lb": round(meas["baseline_lb"], 4),
            "points_in": [round(float(x), 3) for x in points_in]}
    t_re = truth["drawn"].get("temperature", {}).get("retest_c", 21.0)
    retest_meta = {"weight_lb": round(meas["retest_lb"], 4),
                   "accelerometer_mass_g": round(1e3 * retest.sensor_mass_kg, 2),
                   "temperature_c": round(t_re, 1), "tested_on": "2026-05-02"}
    return meta, retest_meta


def _expected_answer(kind: FieldKind, integrity: Integrity | None) -> str:
    """Return the inspection's expected answer for a case of ``kind`` and ``integrity``."""
    if integrity:
        return "inconclusive"
    return "altered" if kind != "none" else "not_altered"


def draw_case(
    rng: np.random.Generator, kind: FieldKind | RulebookKind = "none", nuisances=nz.NUISANCES,
    integrity: Integrity | None = None, serial: str = "SIM-0001",
) -> FieldCase:
    """Draw a random bat with its lab files and its hidden truth.

    The draws come in a fixed order (profile, wood, test set-up, rig, wood fields, planes and
    cup, alteration, other bat, scale readings), so a seed gives the same case every time.

    Parameters
    ----------
    rng : numpy.random.Generator
        The source of every random draw.
    kind : {"none", "cork", ...}
        "none" (unaltered), one of ``alterations.KINDS`` (cores) or of
        ``rulebook.RULEBOOK_KINDS`` (nails, shaved, wax, legal grips, ...).
    nuisances : iterable of str
        The nuisances to draw (``nuisances.NUISANCES`` and ``OPTIONAL_NUISANCES``).
    integrity : str or None
        None or a data-integrity slip of ``INTEGRITY``.
    serial : str
        The bat's serial in meta.json.

    Returns
    -------
    FieldCase
        The lab's files (as objects) and the truth behind them.
    """
    nuis = tuple(nuisances)
    _check_request(kind, nuis, integrity)
    on = set(nuis)
    rec: dict = {}
    truth_profile, profile = _draw_profiles(rng)
    length_m = truth_profile.length_m
    species, wood = random_wood(rng)
    nominal = material_from_imperial(*SPECIES[species])
    points_in, fmax, noise = _draw_test_setup(rng, on, profile, nominal, integrity, rec)
    base = VirtualBat(truth_profile, wood, points_in * IN_TO_M, rel_noise=noise,
                      n_averages=nz.COHERENCE_AVERAGES if "coherence" in on else None)
    base, re_changes = _draw_rig(rng, on, base, rec)
    base_field, re_changes["wood"] = _draw_wood_fields(rng, on, length_m, rec)
    base = replace(base, wood=base_field)
    base, cup_depth_in = _draw_planes_and_cup(rng, on, base, re_changes, rec)

    retest = replace(base, **re_changes)
    truth = {"kind": kind, "altered": kind != "none", "integrity": integrity,
             "expected": _expected_answer(kind, integrity),
             "nuisances": list(nuis), "drawn": rec, "serial": serial}
    if kind in RULEBOOK_KINDS:  # the rulebook's changes: all in updating.simulate.rulebook
        change = draw_change(rng, kind, truth_profile, wood.rho_kg_m3, cup_depth_in + 0.25)
        retest = replace(retest, local_changes=change.changes)
        truth.update(change.truth(integrity))
    elif kind != "none":
        alt = draw_alteration(rng, kind, length_m / IN_TO_M, min_plug_in=cup_depth_in + 0.25)
        retest = replace(retest, core=alt.core, cavities=retest.cavities + alt.cavities)
        truth.update(alt.truth())
    else:
        truth.update(region_in=None, core_diameter_in=None, fill_density_ratio=None)
    if integrity == "other_bat":
        _, other_wood = random_wood(rng, species)
        retest = replace(retest, material=replace(other_wood, e_over_g=retest.material.e_over_g))

    lab_readings(rng, base, retest, truth)
    meta, retest_meta = _lab_meta(serial, species, points_in, retest, truth)
    freq = np.arange(0.0, fmax + 0.25, 0.5)
    return FieldCase(profile, meta, retest_meta, base, retest, freq, integrity, truth)


def alter_case(
    case: FieldCase, alteration: Alteration, rng: np.random.Generator,
    serial: str | None = None,
) -> FieldCase:
    """Re-test the same bat under the same conditions with ``alteration`` instead of its own.

    Clean bats get a core added; weights, balance points and retest.json's weight are read
    again. For paired studies: one baseline, many re-tests.

    Parameters
    ----------
    case : FieldCase
        The bat and its re-test conditions.
    alteration : Alteration
        The alteration of the new re-test.
    rng : numpy.random.Generator
        The scale readings' noise.
    serial : str or None
        A new serial, or None to keep the case's.

    Returns
    -------
    FieldCase
        The case with the new re-test, truth and retest.json content.
    """
    cup = case.baseline.cavities  # the baseline's cavities are the bat's own (the cup)
    retest = replace(case.retest, core=alteration.core, cavities=cup + alteration.cavities)
    truth = dict(case.truth, altered=True,
                 expected="inconclusive" if case.integrity else "altered")
    truth.update(alteration.truth())
    if serial is not None:
        truth["serial"] = serial
    lab_readings(rng, case.baseline, retest, truth)
    retest_meta = dict(case.retest_meta, weight_lb=round(truth["lab_readings"]["retest_lb"], 4))
    meta = case.meta if serial is None else dict(case.meta, serial=serial)
    return replace(case, meta=meta, retest_meta=retest_meta, retest=retest, truth=truth)


def restage(
    case: FieldCase, baseline: VirtualBat, retest: VirtualBat, freq_hz: np.ndarray,
    rng: np.random.Generator, drawn: dict, nuisances, changes=(),
) -> FieldCase:
    """Test the same bat under other conditions: the hook for nuisances drawn elsewhere.

    ``case`` gives the bat (profile, wood, species, serial); ``baseline`` and ``retest`` are
    its two tests as another drawer set them up (impact points, band, accelerometer,
    bungees, wood fields, planes, and any rulebook ``changes`` already applied to
    ``retest``). The scale is read again (``lab_readings``) and meta.json's and
    retest.json's content written from the new tests, as ``draw_case`` writes them.

    Parameters
    ----------
    case : FieldCase
        A case of the bat (``draw_case``; only its bat and serial are kept).
    baseline, retest : VirtualBat
        The truth of the two tests.
    freq_hz : numpy.ndarray
        The frequency lines of both tests, Hz.
    rng : numpy.random.Generator
        The scale readings' noise.
    drawn : dict
        JSON-able record of the conditions (``truth["drawn"]``); a ``temperature`` entry
        with ``baseline_c`` and ``retest_c`` sets retest.json's and the registration's
        temperatures (else 21 C).
    nuisances : iterable of str
        The names of the nuisances drawn (``truth["nuisances"]``).
    changes : iterable of RulebookChange
        The rulebook changes of the re-test (their truth goes into the case's, the last
        one's top-level keys winning); none: a clean bat.

    Returns
    -------
    FieldCase
        The case with the new tests, lab files' content and truth.
    """
    truth = {"kind": "none", "altered": False, "integrity": None, "expected": "not_altered",
             "nuisances": list(nuisances), "drawn": drawn, "serial": case.truth["serial"],
             "region_in": None, "core_diameter_in": None, "fill_density_ratio": None}
    for change in changes:
        truth.update(change.truth())
    lab_readings(rng, baseline, retest, truth)
    points_in = np.asarray(baseline.points_m, dtype=float) / IN_TO_M
    meta, retest_meta = _lab_meta(case.meta["serial"], case.meta["species"], points_in, retest,
                                  truth)
    return FieldCase(case.profile, meta, retest_meta, baseline, retest, np.asarray(freq_hz),
                     None, truth)


def write_retest(
    case: FieldCase, uff_path, json_path, seed: int, retest_meta_keys=None,
) -> Path | None:
    """Write the re-test's file (slip applied, noise ``seed``) and its retest.json.

    retest.json holds only the ``retest_meta_keys`` given (default all; none: not written).
    Returns the JSON's path or None.
    """
    write_test(uff_path, corrupt(simulate_test(case.retest, case.freq_hz, seed=seed),
                                 case.integrity))
    keys = list(case.retest_meta) if retest_meta_keys is None else list(retest_meta_keys)
    if not keys:
        return None
    Path(json_path).write_text(json.dumps({k: case.retest_meta[k] for k in keys}, indent=1))
    return Path(json_path)


def write_retest_profile(case: FieldCase, path, seed: int, orientations: int = 4) -> dict:
    """Write the re-test's caliper profile (``calipers.retest_survey``) and return its truth.

    Drawn from its own generator (``seed``, 38), so the case's other files are those
    written without it.
    """
    survey, truth = retest_survey(np.random.default_rng([seed, 38]), case.retest, orientations,
                                  mark_deg=case.baseline.theta_deg)
    write_survey_csv(path, survey)
    return truth


def write_case(
    case: FieldCase, folder, seed: int, retest_meta_keys=None, truth: bool = False,
    registration: bool = False, retest_profile: int = 0,
) -> dict:
    """Write a case's lab files into ``folder``.

    profile.csv, meta.json, baseline.uff, retest.uff, retest.json (only the
    ``retest_meta_keys`` given, default all; none: no retest.json) and, with ``truth``,
    truth.json. With ``registration`` meta.json also holds
    ``FieldCase.registration_conditions`` (the baseline's temperature and accelerometer mass,
    as a lab records them at registration). With ``retest_profile`` N > 0, the re-test's
    caliper profile at N orientations, retest_profile.csv (its truth under
    ``retest_profile`` in truth.json).

    Returns
    -------
    dict
        The paths by name (retest_meta None when not written).
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = {k: folder / n for k, n in (("profile", "profile.csv"), ("meta", "meta.json"),
                                        ("baseline", "baseline.uff"), ("retest", "retest.uff"),
                                        ("retest_meta", "retest.json"))}
    write_profile_csv(paths["profile"], case.profile)
    meta = dict(case.meta, **case.registration_conditions) if registration else case.meta
    paths["meta"].write_text(json.dumps(meta, indent=1))
    write_test(paths["baseline"], simulate_test(case.baseline, case.freq_hz, seed=seed))
    paths["retest_meta"] = write_retest(case, paths["retest"], paths["retest_meta"], seed + 1,
                                        retest_meta_keys)
    hidden = dict(case.truth)
    if retest_profile:
        paths["retest_profile"] = folder / "retest_profile.csv"
        hidden["retest_profile"] = write_retest_profile(case, paths["retest_profile"], seed,
                                                        retest_profile)
    if truth:
        paths["truth"] = folder / "truth.json"
        paths["truth"].write_text(json.dumps(hidden, indent=1, default=float))
    return paths


def write_fleet_retest(case: FieldCase, folder, seed: int, orientations: int = 4) -> dict:
    """Write a case's re-test into a fleet folder: SERIAL.uff, SERIAL.json, SERIAL.profile.csv.

    ``batlab fleet inspect DIR`` reads them (docs/contract.md); with ``orientations`` 0 no
    caliper profile. Returns the paths by name.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    serial = case.meta["serial"]
    paths = {"retest": folder / f"{serial}.uff"}
    paths["retest_meta"] = write_retest(case, paths["retest"], folder / f"{serial}.json",
                                        seed + 1)
    if orientations:
        paths["retest_profile"] = folder / f"{serial}.profile.csv"
        write_retest_profile(case, paths["retest_profile"], seed, orientations)
    return paths
