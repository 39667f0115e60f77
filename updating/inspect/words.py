"""The verdict's numbers and causes in one wording for the lab (terminal, JSON reasons, report).

A p-value is said one way everywhere: "chance an unaltered bat differs this much: 4.2 %"
(``chance``); a drift the re-test needs beyond what wood and set-up can do is said as what
to check (``what_to_check``), not by the method's parameter names.
"""

from __future__ import annotations

CHANCE = "chance an unaltered bat differs this much"
"""The p-value's one wording."""

CHECKS = {
    "stiffness_beyond_moisture_pct": "the wood's stiffness (room temperature, the wood "
                                     "settled at the baseline's humidity)",
    "density_pct": "the bat's weight (re-weigh it)",
    "sensor_shift_in": "the accelerometer's position (at its baseline point)",
    "knob_end_moisture_pt": "the moisture at the knob end (let the bat settle at the "
                            "baseline's humidity)",
    "barrel_end_moisture_pt": "the moisture at the barrel end (let the bat settle at the "
                              "baseline's humidity)",
    "sensor_mass_change_g": "the accelerometer's mass (the baseline's accelerometer and cable)",
    "plane_mix": "the tapping direction (the baseline's grain plane)",
    "handle_substance_g": "grip substance on the handle (clean the handle)",
    "handle_substance_to_in": "grip substance on the handle (clean the handle)",
    "handle_substance_from_in": "grip substance on the handle (clean the handle)",
}
"""What to check for each drift parameter of ``updating.inspect.hypotheses.NULL_NAMES``."""


def percent(p: float) -> str:
    """Write a probability as the lab reads it: "92 %", "4.2 %", "1 %", "below 0.1 %".

    Parameters
    ----------
    p : float
        The probability, 0-1.

    Returns
    -------
    str
        Percent to two significant digits between 0.1 % and 99 %; "below 0.1 %" and
        "over 99 %" outside.
    """
    if p < 0.001:
        return "below 0.1 %"
    if p > 0.99:
        return "over 99 %"
    return f"{100 * p:.2g} %"


def chance(p: float) -> str:
    """Say a p-value in the one wording: "chance an unaltered bat differs this much: 4.2 %".

    Parameters
    ----------
    p : float
        The p-value: the probability that an unaltered bat's re-test differs at least this
        much from its baseline.

    Returns
    -------
    str
        The clause.
    """
    return f"{CHANCE}: {percent(p)}"


def what_to_check(names) -> str:
    """Name, in lab words, what the held drift parameters point at (duplicates once).

    Parameters
    ----------
    names : iterable of str
        Drift parameter names (``CHECKS``'s keys; an unknown one is named as it is).

    Returns
    -------
    str
        "the accelerometer's mass (...) and the moisture at the barrel end (...)".
    """
    said = list(dict.fromkeys(CHECKS.get(n, n.replace("_", " ")) for n in names))
    return " and ".join(said)
