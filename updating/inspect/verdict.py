"""The result of inspecting a re-test against a bat's reference (phase 3 of the method)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Verdict:
    """Inspection result, SI.

    Attributes:
        altered: the decision.
        confidence: 1 - p-value of the test "no local alteration" (0..1).
        false_alarm_rate: the test's significance level.
        statistic: the test statistic (e.g. F) and its name in ``details``.
        region_m: (start, end) of the altered region from the knob end, or None.
        core_diameter_m, fill_density_ratio: the fitted core, or None when not altered.
        uncertainty: standard uncertainties of the fitted quantities (same keys, SI).
        element_x0_m, element_x1_m: (e,) element ends of the reference mesh; alpha, beta:
            (e,) element mass and bending-stiffness factors implied by the fitted core
            (``updating.msso.core_elements.core_element_factors`` of the H1 core:
            element-averaged section ratios) when altered, zeros when not. They do not come
            from MSSO: the MSSO element map is reported separately in ``details["msso"]``.
        moisture: {"stiffness_scale": ..., "density_scale": ...} uniform drift fitted.
        modes: paired modes, list of dicts {baseline_hz, retest_hz, mac, ...}.
        details: anything else worth reporting (fit residuals, ranks, timings).
    """

    altered: bool
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
    modes: list = field(default_factory=list)
    details: dict = field(default_factory=dict)
