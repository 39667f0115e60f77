"""The inspection's decision: its gates, and its rules read top to bottom (docs/inspection.md).

The evidence (``Evidence``) comes from the nested test of H1 (drift and a local change
anywhere) against H0 (drift, with a grip substance on the handle) and, when the change is
significant, from the kind its physics fits best (``kinds.classify``: a core, added mass, a
lost diameter; ``finding``). The first rule of ``RULES`` whose condition holds gives the
outcome and its reasons:

"Significant" is a chance below ``CLEAR_LEVEL`` of the test with the noise H0 leaves: a
change beyond drift, never acquitted; "beyond" is significant and large against the noise
the best local change leaves (``is_large``: F at ``F_FLOOR`` or more). That chance is
measured where a calibration of the bat's model is stored (``decided_chance``: among its
clean re-tests' F) and the F distribution's where none is, or where it holds too few
re-tests to show a chance below the level.

=====================  ==============================================  ============
rule                   when                                            altered
=====================  ==============================================  ============
another bat            a uniform change beyond physical bounds         None
                       explains the change as well as a local one
grip substance         significant or large, a substance on the        False
                       handle within 18 in of the knob (Rule
                       3.02(c): legal)
grip past 18 in        significant or large, a grip substance          False
                       reaching past 18 in (clean the bat; not an
                       alteration)
alteration             beyond, a kind of alteration large enough for   True
                       its kind (``kind_supported``), no confusable
                       nuisance at its bound (or it beats drift three
                       times beyond the bounds), and it survives
                       leaving out any one mode or point
one mode or point      the same, but resting on one mode or one        None
                       point (``robustness``)
alteration or drift    beyond and large enough, a confusable           None
                       nuisance at its bound in H0 or beside the
                       finding, and that drift three times as far
                       (and the end grain's three times as deep)
                       explains the change at the stated chance, or
                       leaves it small
unexplained change     significant, local, but no kind fits it         None
weight                 significant, weight changed beyond moisture     None
below its gate         significant, the best reading an alteration     None
                       below its kind's gate or not beyond: never
                       acquitted
large change           not significant, but large and read as an      None
                       alteration: never acquitted
drift beyond bounds    a nuisance the data want beyond its bound       None
drift                  otherwise (a grip substance H0 read on the      False
                       handle is named in its reasons: legal)
=====================  ==============================================  ============

``not_altered`` means no change beyond drift or a legal grip: a change whose best reading
is an alteration, however small, is inconclusive with what to do, never acquitted.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from updating.inspect.finding import Finding, describe
from updating.inspect.kind_table import UNEXPLAINED, Kind, kind_of
from updating.inspect.words import chance, what_to_check
from updating.tails import can_measure_below, measured_chance

CLEAR_LEVEL = 1e-3
"""The smallest chance of the nested test (with the noise H0 leaves, which on unaltered bats
follows its nominal F distribution: docs/inspection.md, "Two noises") with which a bat is
cleared (``not_altered``): a change an unaltered bat makes less often than this is never
acquitted; it is an alteration, a legal grip, or inconclusive with what to do. An
alteration needs it too."""
F_FLOOR = 9.0
"""Floor on F against the noise the best local change leaves (``NestedTest.F_fit``) for an
alteration: its size beside the test's own noise, the second key beside the chance
(``CLEAR_LEVEL``). Set in issue 24 (27 % above the largest such F of a clean or legally
gripped bat whose reading passed its kind's gate, 7.0 on 288 inspections). That F's
distribution on clean bats is heavier than F(q, N - p_1) (its noise is fitted to the
alternative), so it states no chance: the chance comes from the test with H0's noise."""
WEIGHT_DRIFT_MAX = 0.04
"""|ln(W_retest / W_registered)| beyond which moisture (+-2.5 points, 1 %/point, plus the
scale) cannot explain a weight change."""
CONFUSABLE = ("barrel_end_moisture_pt", "sensor_mass_change_g", "sensor_shift_in")
"""Nuisances that act where a core does (the barrel end): a core fit that needs one of them
at its physical bound cannot be told from that drift. (A uniform scale at its bound beside
a core only says the core model is not the alteration's exact shape.)"""


GRIP_MIN_G = 1.0
"""A grip substance read by H0 (less two standard uncertainties) that is reported."""


def is_significant(p_value: float, false_alarm: float) -> bool:
    """Tell whether a change is beyond drift: its chance below ``CLEAR_LEVEL`` and the level.

    Parameters
    ----------
    p_value : float
        The nested test's chance with the noise H0 leaves (``NestedTest.p_value``).
    false_alarm : float
        The significance level (``batlab inspect --false-alarm``).

    Returns
    -------
    bool
        ``p_value < min(CLEAR_LEVEL, false_alarm)``.
    """
    return p_value < min(CLEAR_LEVEL, false_alarm)


def decided_chance(F: float, p_nominal: float, clean_F: np.ndarray | None,
                   false_alarm: float) -> tuple[float, str]:
    """Return the chance the decision reads for a test's F, and where it comes from.

    Measured where a calibration of the bat's model is stored: (1 + b) / (n + 1), b of its n
    clean re-tests' F at least this F (``updating.tails.measured_chance``; Davison &
    Hinkley 1997, eq. 4.11), when n re-tests can show a chance below the decision's level
    (1 / (n + 1) below ``min(CLEAR_LEVEL, false_alarm)``: n of 1,000 or more at the default
    levels). Else the F distribution's p-value, ``p_nominal``: without a calibration, or with
    too few re-tests to measure a chance that small (a 64-re-test calibration's smallest
    chance is 1 / 65).

    Parameters
    ----------
    F : float
        The test's statistic.
    p_nominal : float
        Its p-value from the F distribution.
    clean_F : numpy.ndarray or None
        The calibration's clean re-tests' F (NaN: a re-test without a test), or None.
    false_alarm : float
        The decision's false-alarm rate.

    Returns
    -------
    chance : float
        The chance.
    source : str
        "calibration" or "nominal".

    Examples
    --------
    >>> decided_chance(6.0, 2e-4, None, 0.01)
    (0.0002, 'nominal')
    >>> decided_chance(6.0, 2e-4, np.linspace(0.0, 5.0, 3000), 0.01)  # beyond all 3,000
    (0.0003332222592469177, 'calibration')
    >>> decided_chance(6.0, 2e-4, np.linspace(0.0, 5.0, 64), 0.01)  # 1 / 65 > 1e-3
    (0.0002, 'nominal')
    """
    if (clean_F is None or not np.isfinite(F)
            or not can_measure_below(np.size(clean_F), min(CLEAR_LEVEL, false_alarm))):
        return float(p_nominal), "nominal"
    return measured_chance(F, clean_F).value, "calibration"


def is_large(F_fit: float, p_fit: float, false_alarm: float) -> bool:
    """Tell whether a change is large against the noise the best local change leaves.

    Parameters
    ----------
    F_fit, p_fit : float
        The nested test with the noise the best local change leaves (``NestedTest``).
    false_alarm : float
        The significance level (``batlab inspect --false-alarm``).

    Returns
    -------
    bool
        ``p_fit < false_alarm`` and ``F_fit >= F_FLOOR``.
    """
    return p_fit < false_alarm and F_fit >= F_FLOOR


def kind_supported(finding: Finding | None) -> bool:
    """Tell whether a finding is large enough for its kind to be an alteration.

    Its kind's reading must exceed the kind's gate (``kind_table.Kind.gate``: a core's
    diameter, an insert's or a coat's mass, a lost diameter) by two standard uncertainties;
    a grip substance and a change no kind explains have no gate and never are.

    Parameters
    ----------
    finding : Finding or None
        What the change's physics fits best.

    Returns
    -------
    bool
    """
    k = None if finding is None else kind_of(finding.kind, finding.rule)
    if k is None or k.gate is None:
        return False
    return k.gate.passed(finding.reading, finding.uncertainty)


@dataclass(frozen=True)
class Evidence:
    """What the decision reads: the test, the finding and the checks on the fits.

    Attributes
    ----------
    F, p_value : float
        The nested test (H1 against H0): F and its F distribution's p-value (the reasons
        are worded with it; ``batlab`` restates them with the chance it states).
    significant : bool
        The change is beyond drift (``is_significant`` of the decided chance,
        ``decided_chance``).
    large : bool
        Large against the noise the best local change leaves (``is_large``), significant
        or not.
    finding : Finding or None
        The kind the change fits best, when significant.
    finding_text : str
        The finding in words (where, how much).
    held_null, held_core : tuple of str
        Nuisances H0 holds at their physical bounds; the ``CONFUSABLE`` ones H0 or the
        finding's fit holds there (the finding may be that drift, beyond its bound).
    dlnw : float or None
        ln(W_retest / W_registered), None when either weight is unknown.
    grip : Finding or None
        A legal grip substance H0 read on the handle (``GRIP_MIN_G`` or more), else None.
    uniform : tuple of float or None
        (stiffness %, density %) of a uniform change beyond the bounds that explains the
        change as well as the local one (another bat), else None.
    F_wide : float or None
        F of the local change against drift three times beyond the bounds when it stays
        significant, else None.
    drift_beyond_bounds : bool
        The data want H0's held nuisances beyond their bounds (evaluated only when the
        change is not significant).
    F_fit : float
        The nested test's F with the noise the best local change leaves.
    rests_on : tuple of str
        What the finding rests on alone: the modes and points whose leave-out it does not
        survive (``robustness.leave_one_out``), each with the F left without it; empty when
        it survives every leave-out or was not checked.
    decided_on : str
        Where the chance ``significant`` read comes from: "calibration" (measured on the
        bat model's clean re-tests) or "nominal" (``decided_chance``).
    """

    F: float
    p_value: float
    significant: bool
    large: bool
    finding: Finding | None
    finding_text: str
    held_null: tuple[str, ...]
    held_core: tuple[str, ...]
    dlnw: float | None
    grip: Finding | None = None
    uniform: tuple[float, float] | None = None
    F_wide: float | None = None
    drift_beyond_bounds: bool = False
    F_fit: float = float("nan")
    rests_on: tuple[str, ...] = ()
    decided_on: str = "nominal"

    @property
    def beyond(self) -> bool:
        """Significant and large against the noise the best local change leaves."""
        return self.significant and self.large

    @property
    def would_alter(self) -> bool:
        """Whether the evidence calls the bat altered unless the finding rests on one datum.

        Significant, no other bat, an alteration large enough for its kind, told apart from
        any confusable nuisance at its bound: what the leave-one-out check is run for.
        """
        return (self.beyond and self.uniform is None and self.supported
                and (not self.held_core or self.F_wide is not None))

    @property
    def supported(self) -> bool:
        """Whether the finding is an alteration large enough for its kind."""
        return kind_supported(self.finding)

    @property
    def kind(self) -> Kind | None:
        """The finding's kind in the table of kinds, or None."""
        return None if self.finding is None else kind_of(self.finding.kind, self.finding.rule)

    @property
    def grip_kind(self) -> bool:
        """Whether the finding is a grip substance (a kind that is never an alteration)."""
        return self.kind is not None and not self.kind.alteration

    @property
    def named(self) -> bool:
        """Whether the finding is of a named kind (not the change no kind explains)."""
        return self.kind is not None and self.kind.name != UNEXPLAINED

    @property
    def unexplained(self) -> bool:
        """Whether the finding is the change no named kind explains."""
        return self.kind is not None and self.kind.name == UNEXPLAINED

    @property
    def weight_note(self) -> str:
        """The weight change since registration as a clause ('' when unknown)."""
        if self.dlnw is None:
            return ""
        return f"; weight {100 * np.expm1(self.dlnw):+.1f} % since registration"


def _another_bat(e: Evidence) -> list[str]:
    return [f"the tests differ as two bats of this profile would (uniform stiffness "
            f"{e.uniform[0]:+.1f} %, density {e.uniform[1]:+.1f} %), far beyond what moisture "
            "and temperature do: check that the re-test is of this bat (serial) and the "
            "registered baseline is its own"]


def _grip(e: Evidence) -> list[str]:
    return [f"{e.finding_text}: a grip substance, legal under Rule 3.02(c); no "
            f"alteration{e.weight_note}"]


def _grip_past(e: Evidence) -> list[str]:
    return [f"{e.finding_text}: a grip substance that reaches past 18 in from the knob; the "
            "bat must be cleaned before play (Rule 3.02(c)), which is not an alteration"]


def _altered(e: Evidence) -> list[str]:
    beyond = "" if not e.held_core else (
        f"; not even {what_to_check(e.held_core)}, changed three times as far as it "
        "physically can, would explain it")
    return [f"the change between the tests is not one moisture, temperature, the "
            f"accelerometer or a grip can make ({chance(e.p_value)})"
            f"{e.weight_note}{beyond}", f"it fits {e.finding_text}"]


def _one_datum(e: Evidence) -> list[str]:
    return [f"the change between the tests fits {e.finding_text} ({chance(e.p_value)}), but "
            f"rests on {_listed(e.rests_on)} alone: without it the change is not surely that "
            "alteration. Re-test the bat (same points, band and accelerometer) and check "
            "the accelerometer's mounting and the hammer's hits at that point"]


def _listed(items: tuple[str, ...]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + f" or {items[-1]}"


def _weigh(e: Evidence) -> str:
    """Ask for the scale and retest.json only when the re-test's weight was not given."""
    return ("weigh the bat, give retest.json (weight, accelerometer mass, temperature), "
            if e.dlnw is None else "")


def _altered_or_drift(e: Evidence) -> list[str]:
    return [f"the change between the tests fits {e.finding_text}, but also fits "
            f"{what_to_check(e.held_core)} changed as far as it physically can: an alteration and "
            f"that change cannot be told apart; {_weigh(e)}re-test after a week at the "
            "baseline's conditions"]


def _large(e: Evidence) -> list[str]:
    todo = f"{_weigh(e)}X-ray the barrel end and re-test it in a week at the baseline's " \
        "conditions"
    return [f"the change between the tests fits {e.finding_text} and stands out of the "
            f"test's own noise, though it is not surely beyond drift at the stated chance "
            f"({chance(e.p_value)}){e.weight_note}: not cleared. {todo[0].upper()}{todo[1:]}"]


def _unexplained(e: Evidence) -> list[str]:
    return [f"the tests differ locally beyond noise ({e.finding_text}; {chance(e.p_value)}), "
            "but not as any alteration or legal change does: look the bat over (cracks, "
            "repairs, something attached), check the accelerometer's mounting and re-test"]


def _weight(e: Evidence) -> list[str]:
    return [f"the weight changed by {100 * np.expm1(e.dlnw):+.1f} %, more than moisture "
            f"does, and the tests differ ({chance(e.p_value)}), but no alteration surely "
            f"explains it (best: {e.finding_text}): check that the re-test is of this bat and "
            "re-weigh it"]


def _below_gate(e: Evidence) -> list[str]:
    how = "too little to be sure of an alteration of that kind" if e.beyond else \
        "not surely beyond what the model's own error makes"
    return [f"the tests differ beyond what moisture, temperature and the accelerometer make "
            f"({chance(e.p_value)}), most like {e.finding_text}, but {how}{e.weight_note}: "
            "not cleared either. X-ray the barrel end (a core or nails show), "
            f"{'weigh the bat and ' if e.dlnw is None else 'then '}re-test it in a week at the "
            "baseline's conditions"]


def _drift_beyond_bounds(e: Evidence) -> list[str]:
    return [f"the re-test differs from the baseline beyond physical bounds of what "
            f"moisture, temperature and the set-up do: check {what_to_check(e.held_null)}, "
            "then re-test at the baseline's conditions (same accelerometer, temperature, "
            "after the wood has settled)"]


def _drift(e: Evidence) -> list[str]:
    grip = "" if e.grip is None else (
        f"; {describe(e.grip)}: a grip substance, legal under Rule 3.02(c)")
    return [f"the change between the tests is what moisture, temperature and the "
            f"accelerometer make ({chance(e.p_value)}){e.weight_note}{grip}"]


@dataclass(frozen=True)
class Rule:
    """One row of the decision: when it applies, the outcome, and the reasons it gives.

    Attributes
    ----------
    name : str
        A short name of the rule.
    applies : callable
        ``applies(evidence) -> bool``.
    altered : bool or None
        The outcome (None: inconclusive).
    reasons : callable
        ``reasons(evidence) -> list of str``.
    """

    name: str
    applies: Callable[[Evidence], bool]
    altered: bool | None
    reasons: Callable[[Evidence], list[str]]


RULES = (
    Rule("another bat", lambda e: e.uniform is not None, None, _another_bat),
    Rule("grip substance", lambda e: e.grip_kind and e.finding.legal, False, _grip),
    Rule("grip past 18 in", lambda e: e.grip_kind, False, _grip_past),
    Rule("alteration", lambda e: e.would_alter and not e.rests_on, True, _altered),
    Rule("one mode or point", lambda e: e.would_alter, None, _one_datum),
    Rule("alteration or drift", lambda e: e.beyond and e.supported, None,
         _altered_or_drift),
    Rule("unexplained change", lambda e: e.significant and e.unexplained, None,
         _unexplained),
    Rule("weight", lambda e: e.significant and e.dlnw is not None
         and abs(e.dlnw) > WEIGHT_DRIFT_MAX, None, _weight),
    Rule("below its gate", lambda e: e.significant, None, _below_gate),
    Rule("large change", lambda e: e.large and e.named, None, _large),
    Rule("drift beyond bounds", lambda e: e.drift_beyond_bounds, None, _drift_beyond_bounds),
    Rule("drift", lambda e: True, False, _drift),
)
"""The decision, first matching rule wins (module docstring)."""


def decide(evidence: Evidence) -> tuple[bool | None, list[str]]:
    """Apply the first rule of ``RULES`` that holds for the evidence.

    Parameters
    ----------
    evidence : Evidence
        The nested test and the checks made on its fits.

    Returns
    -------
    altered : bool or None
        True altered, False not altered, None inconclusive.
    reasons : list of str
        The rule's reasons, in words for the lab.
    """
    rule = next(r for r in RULES if r.applies(evidence))
    return rule.altered, rule.reasons(evidence)
