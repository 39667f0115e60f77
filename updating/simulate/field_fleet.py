"""Nuisance-rich virtual bats as a lab hands them over: lab files plus the hidden truth.

``draw_case`` makes one bat: a random pro profile (caliper noise on the lab's copy), a random
species with E within +-15 % and density within +-8 % of its handbook values (meta.json gives
the handbook values), a 2-6 g accelerometer up to 0.05 in off its labelled point near the
barrel end, two bungees of 100-400 N/m; then every nuisance asked for
(``updating.simulate.nuisances``, each switchable on its own), an alteration of the re-test
(``updating.simulate.alterations``) or none, and optionally a data-integrity slip
(``updating.simulate.integrity``). ``write_case`` writes the contract's files: profile.csv,
meta.json, baseline.uff, retest.uff and retest.json (weight_lb, accelerometer_mass_g,
temperature_c, tested_on). ``FieldCase.truth`` is the JSON-able hidden truth, with the answer
expected of the inspection: "altered" for an altered bat, "not_altered" for a clean one,
"inconclusive" for a data-integrity case (never "altered").

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
from updating.model.mass_properties import mass_properties
from updating.model.material import Material, material_from_imperial
from updating.model.profile import Profile, write_profile_csv
from updating.model.units import IN_TO_M, LB_TO_KG
from updating.simulate import nuisances as nz
from updating.simulate.alterations import KINDS, Alteration, AlterationKind, draw_alteration
from updating.simulate.fleet import SPECIES, pro_profile
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

    Attributes:
        profile: the caliper profile the lab has (noisy copy of the truth's).
        meta: meta.json's content (handbook values, registered weight, points).
        retest_meta: retest.json's content.
        baseline, retest: the truth of the two tests (the re-test of ``other_bat`` is
            another bat's).
        freq_hz: the frequency lines of both tests.
        integrity: None or one of INTEGRITY (a slip applied to the re-test file).
        truth: JSON-able hidden truth (kind, expected answer, alteration, nuisances drawn,
            true and measured weights and balance points).
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
        return self.truth["kind"]

    @property
    def expected(self) -> str:
        return self.truth["expected"]

    @property
    def registration_conditions(self) -> dict:
        """What a lab may record at registration beside the weight (meta.json's optional
        keys): the baseline's temperature and accelerometer mass, read as retest.json's."""
        t_base = self.truth["drawn"].get("temperature", {}).get("baseline_c", 21.0)
        return {"temperature_c": round(t_base, 1),
                "accelerometer_mass_g": round(1e3 * self.baseline.sensor_mass_kg, 2)}

    @property
    def min_plug_in(self) -> float:
        """The shortest plug an alteration of this bat can have (behind a cupped end)."""
        return self.truth["drawn"].get("cup", {}).get("depth_in", 0.0) + 0.25


def scale_reading(bat: VirtualBat) -> tuple[float, float]:
    """(weight lb, balance point in from the knob) of the bare bat, without reading noise."""
    mp = mass_properties(bat.truth_model())
    return mp.mass_kg / LB_TO_KG, mp.cg_m / IN_TO_M


def bare(bat: VirtualBat) -> VirtualBat:
    """The bat off the rig: no accelerometer, no bungees (what the scale weighs)."""
    return replace(bat, sensor_mass_kg=0.0, bungee_k_n_per_m=0.0)


def lab_readings(rng: np.random.Generator, base: VirtualBat, retest: VirtualBat,
                 truth: dict) -> None:
    """Put the true and the scale's (noisy) weights and balance points of both tests into
    ``truth`` (keys true_weight_lb, true_balance_in, lab_readings)."""
    w_b, cg_b = scale_reading(bare(base))
    w_r, cg_r = scale_reading(bare(retest))
    truth["true_weight_lb"] = {"baseline": w_b, "retest": w_r}
    truth["true_balance_in"] = {"baseline": cg_b, "retest": cg_r}
    truth["lab_readings"] = {k: v + s * rng.standard_normal() for k, v, s in (
        ("baseline_lb", w_b, SCALE_SIGMA_LB), ("retest_lb", w_r, SCALE_SIGMA_LB),
        ("baseline_balance_in", cg_b, BALANCE_SIGMA_IN),
        ("retest_balance_in", cg_r, BALANCE_SIGMA_IN))}


def random_wood(rng: np.random.Generator, species: str | None = None) -> tuple[str, Material]:
    """A species (random unless given) and a board of it: E within +-15 %, density within
    +-8 % of the handbook values, E/G 10-18."""
    if species is None:
        species = list(SPECIES)[int(rng.integers(len(SPECIES)))]
    E_psi, wd = SPECIES[species]
    nominal = material_from_imperial(E_psi, wd)
    wood = Material(nominal.E_pa * rng.uniform(0.85, 1.15),
                    nominal.rho_kg_m3 * rng.uniform(0.92, 1.08), rng.uniform(10.0, 18.0))
    return species, wood


def no_barrel_points_in(length_in: float) -> np.ndarray:
    """A layout that cannot see the barrel: every 2 in up to 15 in, and the end face (where
    the accelerometer goes)."""
    return np.append(np.arange(1.0, NO_BARREL[0], 2.0), np.floor(100 * length_in) / 100)


def draw_case(
    rng: np.random.Generator, kind: FieldKind | RulebookKind = "none", nuisances=nz.NUISANCES,
    integrity: Integrity | None = None, serial: str = "SIM-0001",
) -> FieldCase:
    """A random bat with the ``nuisances`` given, altered by ``kind`` ("none" or one of
    ``alterations.KINDS``) and with an ``integrity`` slip (None or one of INTEGRITY)."""
    nuis = tuple(nuisances)
    unknown = set(nuis) - set(nz.NUISANCES) - set(nz.OPTIONAL_NUISANCES)
    if unknown:
        raise ValueError(f"unknown nuisance(s) {sorted(unknown)}")
    if kind != "none" and kind not in KINDS + RULEBOOK_KINDS:
        raise ValueError(f"unknown alteration kind {kind!r} "
                         f"(none, {', '.join(KINDS + RULEBOOK_KINDS)})")
    if integrity is not None and integrity not in INTEGRITY:
        raise ValueError(f"unknown integrity case {integrity!r} ({', '.join(INTEGRITY)})")
    on = set(nuis)
    rec: dict = {}

    truth_profile = pro_profile(rng)
    L = truth_profile.length_m
    L_in = L / IN_TO_M
    profile = Profile(truth_profile.x_m, truth_profile.diameter_m
                      + 0.003 * IN_TO_M * rng.standard_normal(truth_profile.x_m.size))
    species, wood = random_wood(rng)
    E_psi, wd = SPECIES[species]

    points_in = nz.lab_points_in(L_in)
    if "points" in on:
        points_in = nz.draw_points(rng, L_in)
    if "model_points" in on:
        points_in = nz.draw_model_points(rng, profile, material_from_imperial(E_psi, wd))
    if integrity == "no_barrel_points":
        points_in = no_barrel_points_in(L_in)
    rec["points"] = len(points_in)
    fmax = nz.draw_band(rng) if "band" in on else 3200.0
    rec["fmax_hz"] = fmax
    noise = nz.draw_noise(rng) if "noise" in on else 0.005
    rec["noise"] = noise

    sensor_mass = rng.uniform(0.002, 0.006)
    offset = rng.uniform(-0.05, 0.05) * IN_TO_M
    bungee = rng.uniform(100.0, 400.0)
    base = VirtualBat(truth_profile, wood, points_in * IN_TO_M, sensor_offset_m=offset,
                      sensor_mass_kg=sensor_mass, bungee_k_n_per_m=bungee, rel_noise=noise)
    re_changes: dict = {}
    if "accelerometer" in on:
        m, off, rec["accelerometer"] = nz.draw_accelerometer(rng, sensor_mass, offset)
        re_changes.update(sensor_mass_kg=m, sensor_offset_m=off)
    if "bungees" in on:
        re_changes["bungee_k_n_per_m"], rec["bungees"] = nz.draw_bungees(rng, bungee)

    base_fields, re_fields = [], []
    if "billet" in on:
        f, rec["billet"] = nz.draw_billet(rng, L)
        base_fields.append(f)
        re_fields.append(f)
    if "temperature" in on:
        fb, fr, rec["temperature"] = nz.draw_temperature(rng, L)
        base_fields.append(fb)
        re_fields.append(fr)
    if "moisture" in on:
        f, rec["moisture"] = nz.draw_moisture(rng, L)
        re_fields.append(f)
    if "uniform_drift" in on:
        f, rec["uniform_drift"] = nz.draw_uniform_drift(rng, L)
        re_fields.append(f)
    base = replace(base, wood=nz.combine(*base_fields))
    re_changes["wood"] = nz.combine(*re_fields)

    if "planes" in on:
        eg_r, eg_t, th_b, th_r, rec["planes"] = nz.draw_planes(rng)
        base = replace(base, material=replace(wood, e_over_g=eg_r), e_over_g_t=eg_t,
                       theta_deg=th_b)
        re_changes["theta_deg"] = th_r
    cup_depth_in = 0.0
    if "cup" in on:
        cup, rec["cup"] = nz.draw_cup(rng)
        base = replace(base, cavities=(cup,))
        cup_depth_in = rec["cup"]["depth_in"]

    retest = replace(base, **re_changes)
    truth = {"kind": kind, "altered": kind != "none", "integrity": integrity,
             "expected": "inconclusive" if integrity else
             ("altered" if kind != "none" else "not_altered"),
             "nuisances": list(nuis), "drawn": rec, "serial": serial}
    if kind in RULEBOOK_KINDS:  # the rulebook's changes: all in updating.simulate.rulebook
        change = draw_change(rng, kind, truth_profile, wood.rho_kg_m3, cup_depth_in + 0.25)
        retest = replace(retest, local_changes=change.changes)
        truth.update(change.truth(integrity))
    elif kind != "none":
        alt = draw_alteration(rng, kind, L_in, min_plug_in=cup_depth_in + 0.25)
        retest = replace(retest, core=alt.core, cavities=retest.cavities + alt.cavities)
        truth.update(alt.truth())
    else:
        truth.update(region_in=None, core_diameter_in=None, fill_density_ratio=None)
    if integrity == "other_bat":
        _, other_wood = random_wood(rng, species)
        retest = replace(retest, material=replace(other_wood, e_over_g=retest.material.e_over_g))

    lab_readings(rng, base, retest, truth)
    meas = truth["lab_readings"]
    meta = {"serial": serial, "species": species, "nominal_E_psi": E_psi,
            "nominal_weight_density_lbf_in3": round(wd, 5),
            "weight_lb": round(meas["baseline_lb"], 4),
            "points_in": [round(float(x), 3) for x in points_in]}
    t_re = rec.get("temperature", {}).get("retest_c", 21.0)
    retest_meta = {"weight_lb": round(meas["retest_lb"], 4),
                   "accelerometer_mass_g": round(1e3 * retest.sensor_mass_kg, 2),
                   "temperature_c": round(t_re, 1), "tested_on": "2026-05-02"}
    freq = np.arange(0.0, fmax + 0.25, 0.5)
    return FieldCase(profile, meta, retest_meta, base, retest, freq, integrity, truth)


def alter_case(
    case: FieldCase, alteration: Alteration, rng: np.random.Generator,
    serial: str | None = None,
) -> FieldCase:
    """The same bat and the same re-test conditions with ``alteration`` instead of the
    re-test's own (clean bats: a core added); weights, balance points and retest.json's
    weight re-read. For paired studies: one baseline, many re-tests."""
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


def write_retest(
    case: FieldCase, uff_path, json_path, seed: int, retest_meta_keys=None,
) -> Path | None:
    """Write the re-test's file (slip applied, noise ``seed``) and its retest.json (only the
    ``retest_meta_keys`` given, default all; none: not written). The JSON's path or None."""
    write_test(uff_path, corrupt(simulate_test(case.retest, case.freq_hz, seed=seed),
                                 case.integrity))
    keys = list(case.retest_meta) if retest_meta_keys is None else list(retest_meta_keys)
    if not keys:
        return None
    Path(json_path).write_text(json.dumps({k: case.retest_meta[k] for k in keys}, indent=1))
    return Path(json_path)


def write_case(
    case: FieldCase, folder, seed: int, retest_meta_keys=None, truth: bool = False,
    registration: bool = False,
) -> dict:
    """Write profile.csv, meta.json, baseline.uff, retest.uff, retest.json (only the
    ``retest_meta_keys`` given, default all; none: no retest.json) and, with ``truth``,
    truth.json into ``folder``; returns the paths by name (retest_meta None when not written).
    With ``registration`` meta.json also holds ``FieldCase.registration_conditions`` (the
    baseline's temperature and accelerometer mass, as a lab records them at registration).
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
    if truth:
        paths["truth"] = folder / "truth.json"
        paths["truth"].write_text(json.dumps(case.truth, indent=1, default=float))
    return paths
