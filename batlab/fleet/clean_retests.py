"""One registered bat and its clean re-tests, drawn with every nuisance and legal grip.

``draw_bat`` makes the bat of a lab's profile.csv and meta.json as it stood at its baseline
test: its wood within the handbook's spread (E +-15 %, density matched to meta.json's weight),
billet gradients, two bending planes, a cupped end, a 2-6 g accelerometer, bungees, the FRF
noise and band (``updating.simulate.nuisances``, drawn once). ``draw_retest`` makes one clean
re-test of it: temperature, end-grain moisture, the grain angle, a replaced or re-mounted
accelerometer, re-hung bungees and, on three bats in four, a legal grip on the handle (pine
tar, grip tape or spray; ``updating.simulate.rulebook``), with the scale's readings
(``updating.simulate.field_fleet``). Both take a ``numpy.random.Generator``; the draws come
in a fixed order, so a seed gives the same bat and the same re-test everywhere.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from batlab.pipeline import IN_TO_M
from updating.simulate import nuisances as nz
from updating.simulate.field_fleet import BALANCE_SIGMA_IN, SCALE_SIGMA_LB, bare, scale_reading
from updating.simulate.rulebook import LEGAL_KINDS, draw_change
from updating.simulate.virtual_bat import VirtualBat
from updating.simulate.wood import temperature_field

GRIPS = (None, *LEGAL_KINDS)
"""A re-test's handle: bare, or one of the rulebook's legal grips, even odds."""
DF_HZ = 0.5


@dataclass(frozen=True)
class CleanBat:
    """A bat at its baseline test and what its re-tests keep of it.

    Attributes
    ----------
    baseline : VirtualBat
        The truth of the baseline test.
    meta : dict
        meta.json as the lab registers it (``weight_lb`` the scale's reading of this bat).
    freq_hz : numpy.ndarray
        The frequency lines of every test, Hz.
    billet : WoodField
        The billet's gradients (both tests).
    baseline_c, per_c : float
        The baseline's temperature (C) and the wood's stiffness change per degree (1/C).
    drawn : dict
        JSON-able record of the bat's draws.
    """

    baseline: VirtualBat
    meta: dict
    freq_hz: np.ndarray
    billet: object
    baseline_c: float
    per_c: float
    drawn: dict


@dataclass(frozen=True)
class CleanRetest:
    """One clean re-test of a ``CleanBat``.

    Attributes
    ----------
    bat : VirtualBat
        The truth of the re-test.
    retest_meta : dict
        retest.json's content (weight_lb, accelerometer_mass_g, temperature_c, tested_on).
    grip : str or None
        The legal grip on the handle (None: bare).
    noise_seed : int
        The seed of the re-test's FRF noise.
    drawn : dict
        JSON-able record of the re-test's draws.
    """

    bat: VirtualBat
    retest_meta: dict
    grip: str | None
    noise_seed: int
    drawn: dict


def _weighed(base: VirtualBat, weight_lb: float | None, rng: np.random.Generator) -> VirtualBat:
    """Scale the bat's density to meta.json's weight (else draw it within +-8 %).

    The bare bat (its billet gradients and cupped end included) then weighs ``weight_lb``;
    mass is linear in the density, so one scaling is exact.
    """
    if weight_lb is None:
        factor = rng.uniform(0.92, 1.08)
    else:
        factor = float(weight_lb) / scale_reading(bare(base))[0]
    return replace(base, material=base.material.scaled(1.0, factor))


def draw_bat(rng: np.random.Generator, profile, nominal, meta: dict) -> CleanBat:
    """Draw the bat of a lab's profile and meta.json at its baseline test.

    Parameters
    ----------
    rng : numpy.random.Generator
        The source of every draw.
    profile : Profile
        The bat's profile (profile.csv), taken as its true outer shape.
    nominal : Material
        meta.json's handbook wood.
    meta : dict
        meta.json's content (its ``points_in`` are the impact points).

    Returns
    -------
    CleanBat
        The bat, its registered meta.json and what its re-tests keep.
    """
    points_m = np.sort(np.asarray(meta["points_in"], dtype=float)) * IN_TO_M
    rec: dict = {"e_scale": rng.uniform(0.85, 1.15)}
    length_m = profile.length_m
    billet, rec["billet"] = nz.draw_billet(rng, length_m)
    t_field, _, rec["temperature"] = nz.draw_temperature(rng, length_m)
    eg_r, eg_t, theta, _, rec["planes"] = nz.draw_planes(rng)
    cup, rec["cup"] = nz.draw_cup(rng)
    rec["noise"], rec["fmax_hz"] = nz.draw_noise(rng), nz.draw_band(rng)
    wood = replace(nominal.scaled(rec["e_scale"], 1.0), e_over_g=eg_r)
    base = VirtualBat(profile, wood, points_m,
                      sensor_offset_m=rng.uniform(-0.05, 0.05) * IN_TO_M,
                      sensor_mass_kg=rng.uniform(0.002, 0.006),
                      bungee_k_n_per_m=rng.uniform(100.0, 400.0), rel_noise=rec["noise"],
                      wood=nz.combine(billet, t_field), cavities=(cup,), e_over_g_t=eg_t,
                      theta_deg=theta, n_averages=nz.COHERENCE_AVERAGES)
    base = _weighed(base, meta.get("weight_lb"), rng)
    rec["rho_scale"] = base.material.rho_kg_m3 / nominal.rho_kg_m3
    registered = dict(meta)
    if meta.get("weight_lb") is not None:
        weight_lb, _ = scale_reading(bare(base))
        registered["weight_lb"] = round(weight_lb + SCALE_SIGMA_LB * rng.standard_normal(), 4)
    freq = np.arange(0.0, rec["fmax_hz"] + DF_HZ / 2, DF_HZ)
    return CleanBat(base, registered, freq, billet, rec["temperature"]["baseline_c"],
                    rec["temperature"]["per_c"], rec)


def draw_retest(rng: np.random.Generator, bat: CleanBat) -> CleanRetest:
    """Draw one clean re-test of ``bat``: every re-test nuisance and, maybe, a legal grip.

    Parameters
    ----------
    rng : numpy.random.Generator
        The source of every draw.
    bat : CleanBat
        The bat at its baseline.

    Returns
    -------
    CleanRetest
        The re-test's truth, its retest.json and what was drawn.
    """
    base = bat.baseline
    length_m = base.profile.length_m
    rec: dict = {}
    retest_c = bat.baseline_c + rng.uniform(-10.0, 10.0)
    rec["temperature_c"] = retest_c
    moisture, rec["moisture"] = nz.draw_moisture(rng, length_m)
    theta = float(np.clip(base.theta_deg + rng.uniform(-10.0, 10.0), 0.0, 90.0))
    mass, offset, rec["accelerometer"] = nz.draw_accelerometer(rng, base.sensor_mass_kg,
                                                               base.sensor_offset_m)
    bungee, rec["bungees"] = nz.draw_bungees(rng, base.bungee_k_n_per_m)
    wood = nz.combine(bat.billet, temperature_field(length_m, retest_c - 20.0, bat.per_c),
                      moisture)
    grip = GRIPS[int(rng.integers(len(GRIPS)))]
    changes = () if grip is None else draw_change(rng, grip, base.profile,
                                                  base.material.rho_kg_m3).changes
    retest = replace(base, wood=wood, theta_deg=theta,
                     sensor_mass_kg=mass, sensor_offset_m=offset, bungee_k_n_per_m=bungee,
                     local_changes=changes)
    weight_lb, balance_in = scale_reading(bare(retest))
    rec["grip"] = grip
    rec["balance_in"] = balance_in + BALANCE_SIGMA_IN * rng.standard_normal()
    retest_meta = {"weight_lb": round(weight_lb + SCALE_SIGMA_LB * rng.standard_normal(), 4),
                   "accelerometer_mass_g": round(1e3 * mass, 2),
                   "temperature_c": round(retest_c, 1), "tested_on": "2026-05-02"}
    return CleanRetest(retest, retest_meta, grip, int(rng.integers(2**31)), rec)
