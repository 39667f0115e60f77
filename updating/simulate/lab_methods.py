"""What a lab would do without batlab: a scale, and a scale with the balance point.

- **scale**: altered when |weight - registered weight| / registered weight exceeds what
  +-2 points of moisture explain (1 %/point: 2 %) plus three sigmas of the difference of two
  scale readings (0.002 lb each);
- **scale + balance point**: the scale's rule, or the balance point moved by more than a
  limit (``clean_balance_limit_in``: the largest shift of clean nuisance-rich bats).
"""

from __future__ import annotations

import numpy as np

from updating.simulate.field_fleet import SCALE_SIGMA_LB, draw_case
from updating.simulate.nuisances import NUISANCES

MOISTURE_ALLOWANCE = 0.02
"""Relative weight change +-2 points of moisture explain (about 1 % of weight a point)."""


def lab_statistics(truth: dict) -> tuple[float, float]:
    """Read the lab's two statistics from a case's scale readings.

    Parameters
    ----------
    truth : dict
        A case's truth with its ``lab_readings`` (``field_fleet.lab_readings``).

    Returns
    -------
    weight_change : float
        |retest - baseline| / baseline weight.
    balance_shift_in : float
        |retest - baseline| balance point, in.
    """
    r = truth["lab_readings"]
    return (abs(r["retest_lb"] - r["baseline_lb"]) / r["baseline_lb"],
            abs(r["retest_balance_in"] - r["baseline_balance_in"]))


def lab_verdicts(truth: dict, balance_limit_in: float) -> dict[str, bool]:
    """Call a re-test altered or not by the scale and by the scale with the balance point.

    Parameters
    ----------
    truth : dict
        The case's truth with its ``lab_readings``.
    balance_limit_in : float
        A balance-point shift above this (in) is an alteration.

    Returns
    -------
    dict of str to bool
        "scale" and "scale+balance": whether each calls the re-test altered.
    """
    dw, dcg = lab_statistics(truth)
    w = truth["lab_readings"]["baseline_lb"]
    scale = dw > MOISTURE_ALLOWANCE + 3 * np.sqrt(2) * SCALE_SIGMA_LB / w
    return {"scale": bool(scale), "scale+balance": bool(scale or dcg > balance_limit_in)}


def clean_balance_limit_in(n: int, seed: int) -> float:
    """Find the largest balance-point shift of ``n`` clean nuisance-rich bats (no FRFs).

    Parameters
    ----------
    n : int
        Clean bats; bat k is drawn with seed ``seed * 7919 + k``.
    seed : int
        The study's seed.

    Returns
    -------
    float
        The largest shift, in (0 for no bats).
    """
    worst = 0.0
    for k in range(n):
        case = draw_case(np.random.default_rng(seed * 7919 + k), "none", NUISANCES)
        worst = max(worst, lab_statistics(case.truth)[1])
    return worst
