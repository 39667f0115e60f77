"""The result of inspecting a re-test against a bat's reference (phase 3 of the method)."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

from updating.inspect.details import InspectionDetails, ModePair
from updating.inspect.finding import Finding

if TYPE_CHECKING:
    from updating.inspect.calipers import CaliperResult
    from updating.inspect.plane_split import PlaneSplit


class Status(str, Enum):
    """The three outcomes of an inspection (the contract's ``status``)."""

    ALTERED = "altered"
    NOT_ALTERED = "not_altered"
    INCONCLUSIVE = "inconclusive"


@dataclass(frozen=True)
class Verdict:
    """Inspection result, SI.

    Attributes
    ----------
    altered
        True (altered), False (not altered) or None (inconclusive: the data cannot support a
        verdict; ``reasons`` say why and what to do).
    confidence
        1 - p-value of the test "no local alteration" (0..1); NaN when no test was made.
    false_alarm_rate
        The test's significance level.
    statistic
        The test statistic (e.g. F) and its name in ``details``.
    region_m
        (start, end) of the altered region from the knob end, or None.
    core_diameter_m, fill_density_ratio
        The fitted core, or None when not altered.
    uncertainty
        Standard uncertainties of the fitted quantities (same keys, SI).
    element_x0_m, element_x1_m
        (e,) element ends.
    alpha, beta
        (e,) element mass and stiffness factors (translational mass, bending stiffness).
    moisture
        {"stiffness_scale": ..., "density_scale": ...} uniform drift fitted.
    modes
        The paired modes (``ModePair``: baseline_hz, retest_hz, mac, ...).
    details
        Everything else worth reporting (``InspectionDetails``: the test, the fits' residuals,
        the position scan, the MSSO map, timings), None when not recorded.
    reasons
        One line each: why altered, why not, or why no verdict is possible.
    finding
        What changed, in the rulebook's words, or None.
    calipers
        The re-test's caliper profile against the registration's
        (``updating.inspect.calipers.CaliperResult``), None without one.
    plane_split
        The flat the bending planes' splits read, or why they cannot tell
        (``updating.inspect.plane_split.PlaneSplit``), None when not read.
    """

    altered: bool | None
    confidence: float
    false_alarm_rate: float
    statistic: float
    region_m: tuple[float, float] | None
    core_diameter_m: float | None
    fill_density_ratio: float | None
    uncertainty: dict
    element_x0_m: np.ndarray
    element_x1_m: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    moisture: dict
    modes: tuple[ModePair, ...] = ()
    details: InspectionDetails | None = None
    reasons: tuple[str, ...] = ()
    finding: Finding | None = None
    calipers: CaliperResult | None = None
    plane_split: PlaneSplit | None = None

    @property
    def status(self) -> Status:
        """Return the verdict's status (altered, not altered or inconclusive)."""
        if self.altered is None:
            return Status.INCONCLUSIVE
        return Status.ALTERED if self.altered else Status.NOT_ALTERED

