"""The virtual lab's moisture meter, test room and calendar: what a lab records of the wood.

``lab_records`` writes, for a drawn bat (``field_fleet.FieldCase``), what the contract's
optional keys hold at registration (meta.json) and at the re-test (retest.json):
``tested_on`` (the registration's, the re-test's being retest.json's), ``humidity_pct``,
``conditioned_h`` and, with ``per_station`` > 0, ``moisture``: a pin meter's readings at
``STATIONS_IN`` (the handle, mid-barrel, the barrel end), ``per_station`` each. The physics
is ``updating.model.wood_moisture``'s (docs/noise.md, "Moisture readings"):

- each bat's wood has its own diffusivity across the grain, drawn within
  ``wood_moisture.D_ACROSS_M2_S``, and along it 10-20 times that;
- the days between the tests are those its end grain's front needed to reach the depth the
  bat's drawn moisture has (``decay_in``, else 1.5-3 in): t = pi l^2 / (4 D_L)
  (``wood_moisture.front_decay_m`` inverted), whole days, rounded up;
- each test's room: 35-60 % humidity, 2-48 h in it before the test; the bat's section at
  registration holds the room's EMC +-1 point, at the re-test that plus the moisture change
  the re-test's wood field has against the baseline's (density +1 % a point);
- a reading is the pin meter's shell after the room (``wood_moisture.shell_reading``) plus
  the meter's error (``moisture_bounds.METER_SD_PT``, Gaussian), to 0.1 point.

Every draw comes from its own generator (``seed``, 47), so a case's other files are those
written without records.
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import replace

import numpy as np

from updating.inspect.moisture_bounds import METER_SD_PT
from updating.model import wood_moisture as wm
from updating.model.units import IN_TO_M
from updating.simulate.field_fleet import FieldCase
from updating.simulate.virtual_bat import VirtualBat
from updating.simulate.wood import MOISTURE_MASS_PER_POINT

STATIONS_IN = (("handle", 8.0), ("mid_barrel", -6.0), ("barrel_end", -1.0))
"""Where the lab reads the wood: inches from the knob end (negative: from the barrel end)."""
HUMIDITY_PCT, CONDITIONED_H = (35.0, 60.0), (2.0, 48.0)
"""A test room's humidity and the hours a bat spends in it before the test."""
FRONT_IN = (1.5, 3.0)
"""The end grain's front depth drawn when the bat's moisture record has none, in."""
RETEST_DATE = "2026-05-02"
"""The re-test's date when retest.json has none (``field_fleet._lab_meta``'s)."""


def moisture_change_pct(base: VirtualBat, retest: VirtualBat, x_m) -> np.ndarray:
    """Return the re-test's moisture change against the baseline at ``x_m``, points.

    From the density the two tests' wood has there (uniform moisture and wood fields; the
    billet is in both and cancels, temperature leaves density alone): 100 (rho_r / rho_b - 1)
    / (100 ``MOISTURE_MASS_PER_POINT``).
    """
    x = np.asarray(x_m, dtype=float)

    def density(bat: VirtualBat) -> np.ndarray:
        field = np.ones_like(x) if bat.wood is None else bat.wood.at(x)[1]
        return (1 + MOISTURE_MASS_PER_POINT * bat.moisture_pct) * field

    return (density(retest) / density(base) - 1) / MOISTURE_MASS_PER_POINT


def station_x_m(length_m: float) -> np.ndarray:
    """Return the stations ``STATIONS_IN`` on a bat ``length_m`` long, m."""
    return np.array([x if x >= 0 else length_m / IN_TO_M + x for _, x in STATIONS_IN]) * IN_TO_M


def _readings(rng: np.random.Generator, x_m: np.ndarray, section_pct: np.ndarray,
              radius_m: np.ndarray, room: dict, diffusivity: float,
              per_station: int) -> list[dict]:
    """Draw a pin meter's readings of one test, ``per_station`` at each station."""
    seconds = room["conditioned_h"] * wm.SECONDS_PER_HOUR
    shell = wm.shell_share(diffusivity, seconds)
    section = np.array([wm.section_share(diffusivity, seconds, r) for r in radius_m])
    shell_pct = wm.shell_reading(section_pct, wm.emc_pct(room["humidity_pct"]), shell, section)
    out = []
    for x, mc in zip(x_m, shell_pct, strict=True):
        for _ in range(per_station):
            value = float(np.clip(mc + METER_SD_PT * rng.standard_normal(), 0.0, 40.0))
            out.append({"x_in": round(float(x) / IN_TO_M, 2), "mc_pct": round(value, 1)})
    return out


def lab_records(case: FieldCase, seed: int, per_station: int = 1) -> dict:
    """Draw what a lab records of the wood and the room at both tests (module docstring).

    Parameters
    ----------
    case : FieldCase
        The bat and its two tests.
    seed : int
        The records' own generator's seed (with 47).
    per_station : int
        Readings at each station (0: dates and rooms, no meter).

    Returns
    -------
    dict
        ``registration`` and ``retest``: the keys meta.json and retest.json gain; ``truth``:
        the diffusivity, days, the section's moisture at registration.
    """
    rng = np.random.default_rng([seed, 47])
    d_across = float(rng.uniform(wm.D_ACROSS_M2_S[0], wm.D_ACROSS_M2_S[2]))
    along = float(rng.uniform(wm.ALONG_GRAIN_RATIO[0], wm.ALONG_GRAIN_RATIO[2]))
    front_in = case.truth["drawn"].get("moisture", {}).get("decay_in")
    front_in = float(rng.uniform(*FRONT_IN)) if front_in is None else float(front_in)
    seconds = math.pi * (front_in * IN_TO_M) ** 2 / (4.0 * d_across * along)
    days = max(1, math.ceil(seconds / wm.SECONDS_PER_DAY))
    rooms = [{"humidity_pct": round(float(rng.uniform(*HUMIDITY_PCT))),
              "conditioned_h": round(float(rng.uniform(*CONDITIONED_H)) * 2) / 2}
             for _ in range(2)]
    registered_mc = float(wm.emc_pct(rooms[0]["humidity_pct"]) + rng.uniform(-1.0, 1.0))
    retest_on = case.retest_meta.get("tested_on", RETEST_DATE)
    registration = {"tested_on": (dt.date.fromisoformat(retest_on)
                                  - dt.timedelta(days=days)).isoformat(), **rooms[0]}
    retest = dict(rooms[1], tested_on=retest_on)
    if per_station > 0:
        length = case.profile.length_m
        x = station_x_m(length)
        radius = 0.5 * case.profile.diameter_at(x)
        change = moisture_change_pct(case.baseline, case.retest, x)
        registration["moisture"] = _readings(rng, x, np.full(x.size, registered_mc), radius,
                                             rooms[0], d_across, per_station)
        retest["moisture"] = _readings(rng, x, registered_mc + change, radius, rooms[1],
                                       d_across, per_station)
    truth = {"diffusivity_across_m2_s": d_across, "along_ratio": along, "front_in": front_in,
             "days": days, "registered_mc_pct": registered_mc, "per_station": per_station}
    return {"registration": registration, "retest": retest, "truth": truth}


def with_lab_records(case: FieldCase, seed: int, per_station: int = 1) -> FieldCase:
    """Return the case with the records of ``lab_records`` in its files' content.

    retest.json gains the re-test's keys; meta.json the registration's, through
    ``FieldCase.registration_conditions`` (``field_fleet.write_case(registration=True)``);
    the truth keeps all of it under ``lab_records``.
    """
    records = lab_records(case, seed, per_station)
    return replace(case, retest_meta=dict(case.retest_meta, **records["retest"]),
                   truth=dict(case.truth, lab_records=records))
