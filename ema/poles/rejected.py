"""Why a candidate pole was not reported as a mode: one record per rejected candidate.

Reasons (``REASONS``): ``stability`` (stable at too few model orders), ``complexity`` (modal
phase collinearity of its shape estimate too low: noise poles are complex), ``band_edge``
(closer to a band edge than its half-power half-width + 2 lines: the edge cuts it; it may
still serve as a computational pole), ``support`` (its contribution at resonance does not
stand above the local misfit), ``merged`` (a second pole inside the first one's half-power
width: one mode reported).
"""

from __future__ import annotations

from dataclasses import dataclass

REASONS = ("stability", "complexity", "band_edge", "support", "merged")


@dataclass(frozen=True)
class Rejection:
    """One rejected candidate.

    Its frequency (Hz), damping ratio, reason and a short detail; ``stable_orders``: model
    orders at which it was stable (0 when not from a sweep).
    """

    freq_hz: float
    damping_ratio: float
    reason: str
    detail: str
    stable_orders: int = 0

    def __post_init__(self) -> None:
        if self.reason not in REASONS:
            raise ValueError(f"unknown rejection reason {self.reason!r}")
