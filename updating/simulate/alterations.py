"""Alterations a re-test may hide, drawn at random: what a corker actually does to a bat.

Every kind is one or two ``Core`` objects (``updating.model.sections``): ``core`` for the
model's single core, and ``cavities`` for an empty stretch next to it. Sizes follow
docs/method.md ("Real bats") (holes 0.75-1.25 in wide, 6-12 in deep, closed with a ~1 in plug).

| kind | what | sizes (in) |
|---|---|---|
| cork | end-bored core, cork fill (density ratio 0.2-0.4) | d 0.5-1.25, filled 3-12, plug 1 |
| deep | starts inside the bat, behind a dowel (Sosa) | d 0.75-1.0, filled 4-8, dowel 3-6 |
| empty | end-bored hole left empty | d 0.75-1.25, 6-11, plug 1 |
| end_plug | dense fill (ratio 2-4) near the end | d 0.75-1.25, filled 2-4, plug 0.5 |
| partial | cork at the hole's bottom (40-70 %), empty above | d 0.75-1.25, hole 8-12, plug 1 |
| small | small cork core | d 0.5, filled 4, plug 1 |
| neutral | soft fill, ratio 0.9-1.1 (a scale cannot see it) | d 0.75-1.25, 6-11, plug 1 |

``min_plug_in`` moves every plug behind a cupped end (a hole is drilled through the cup's
bottom).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np

from updating.model.sections import Core
from updating.model.units import IN_TO_M

AlterationKind = Literal["cork", "deep", "empty", "end_plug", "partial", "small", "neutral"]
"""The alterations of the nuisance-rich fleet (the module's table)."""
KINDS: tuple[AlterationKind, ...] = get_args(AlterationKind)
CORK_RATIO = (0.2, 0.4)


@dataclass(frozen=True)
class Alteration:
    """What was done to the bat, and the reading a perfect inspection would give.

    Attributes
    ----------
    kind : AlterationKind
        One of KINDS.
    core : Core
        The model's core (the filled part).
    cavities : tuple[Core, ...]
        Further cavities (the empty part of a partial fill).
    region_in : tuple[float, float]
        (start, end) of the whole altered stretch from the knob end, in.
    diameter_in : float
        Hole diameter, in.
    fill_density_ratio : float
        Length-weighted mean fill density / wood density over the region.
    """

    kind: AlterationKind
    core: Core
    cavities: tuple[Core, ...]
    region_in: tuple[float, float]
    diameter_in: float
    fill_density_ratio: float

    def truth(self) -> dict:
        """Return the JSON-able truth: kind, region (in), core diameter (in), fill density ratio."""
        return {"kind": self.kind, "region_in": [round(v, 3) for v in self.region_in],
                "core_diameter_in": round(self.diameter_in, 4),
                "fill_density_ratio": round(self.fill_density_ratio, 4)}


def end_bored(
    kind: str, length_in: float, d_in: float, filled_in: float, ratio: float, plug_in: float,
) -> Alteration:
    """One filled core of ``filled_in`` behind a plug of ``plug_in`` at the barrel end."""
    core = Core(d_in * IN_TO_M, (filled_in + plug_in) * IN_TO_M, ratio, 0.0, plug_in * IN_TO_M)
    region = (length_in - plug_in - filled_in, length_in - plug_in)
    return Alteration(kind, core, (), region, d_in, ratio)


def partial_fill(
    length_in: float, d_in: float, hole_in: float, filled_fraction: float, ratio: float,
    plug_in: float,
) -> Alteration:
    """Make a hole of ``hole_in`` behind the plug, its bottom ``filled_fraction`` filled.

    The rest is empty (an empty cavity between the fill and the plug).
    """
    filled = filled_fraction * hole_in
    empty_len = hole_in - filled
    core = Core(d_in * IN_TO_M, (hole_in + plug_in) * IN_TO_M, ratio, 0.0,
                (plug_in + empty_len) * IN_TO_M)
    empty = Core(d_in * IN_TO_M, (plug_in + empty_len) * IN_TO_M, 0.0, 0.0, plug_in * IN_TO_M)
    region = (length_in - plug_in - hole_in, length_in - plug_in)
    return Alteration("partial", core, (empty,), region, d_in, ratio * filled_fraction)


def draw_alteration(
    rng: np.random.Generator, kind: AlterationKind, length_in: float, min_plug_in: float = 0.0,
) -> Alteration:
    """Draw a random alteration of ``kind`` (see the module's table) in a bat ``length_in`` long."""
    u = rng.uniform
    if kind == "cork":
        return end_bored(kind, length_in, u(0.5, 1.25), u(3.0, 12.0), u(*CORK_RATIO),
                         max(1.0, min_plug_in))
    if kind == "deep":
        return end_bored(kind, length_in, u(0.75, 1.0), u(4.0, 8.0), u(*CORK_RATIO),
                         max(u(3.0, 6.0), min_plug_in))
    if kind == "empty":
        return end_bored(kind, length_in, u(0.75, 1.25), u(6.0, 11.0), 0.0,
                         max(1.0, min_plug_in))
    if kind == "end_plug":
        return end_bored(kind, length_in, u(0.75, 1.25), u(2.0, 4.0), u(2.0, 4.0),
                         max(0.5, min_plug_in))
    if kind == "partial":
        return partial_fill(length_in, u(0.75, 1.25), u(8.0, 12.0), u(0.4, 0.7),
                            u(*CORK_RATIO), max(1.0, min_plug_in))
    if kind == "small":
        return end_bored(kind, length_in, 0.5, 4.0, u(*CORK_RATIO), max(1.0, min_plug_in))
    if kind == "neutral":
        return end_bored(kind, length_in, u(0.75, 1.25), u(6.0, 11.0), u(0.9, 1.1),
                         max(1.0, min_plug_in))
    raise ValueError(f"unknown alteration kind {kind!r} (one of {', '.join(KINDS)})")
