"""The rulebook's other alterations and the legal grips, drawn at random on a virtual bat.

MLB Rule 6.03(a)(5) names bats "filled, flat-surfaced, nailed, hollowed, grooved or covered
with a substance such as paraffin, wax"; Rule 3.02(c) lets the handle, up to 18 in from the
knob, be covered with anything that improves the grip. Cores (filled, hollowed) are
``updating.simulate.alterations``; this module draws the rest as ``LocalChange`` objects
(``updating.model.local_change``) that the virtual rig applies last to its truth model.
Sizes (docs/bat_physics.md, "What each change does to a bat"; x from the knob):

kind: what (finding kind, rule words): sizes

- nails: 2-6 steel nails driven axially into the barrel end under a plug (inserted_mass,
  nailed): 0.10-0.16 in thick, 2-3.5 in long, plug 0.5-1 in; mass net of the pilot holes'
  wood; 0-20 % bonded (the steel's bending stiffness about the bat's axis);
- shaved: the barrel turned down (material_removed, flat-surfaced): 0.02-0.1 in off the
  diameter over 4-14 in ending 0.5-2 in from the end;
- flattened: one side planed flat (material_removed, flat-surfaced): a flat 0.02-0.1 in
  deep over 4-14 in, its normal at any angle to the radial plane;
- grooved: rings cut round the barrel (material_removed, grooved): 3-8 rings 0.02-0.06 in
  deep, 0.1-0.25 in wide, 0.5-1.5 in apart;
- wax: wax or paraffin over the barrel (surface_coating, covered with a substance): 3-15 g
  over the last 10-16 in;
- pine_tar, grip_tape, spray: legal grips (handle_substance, grip substance (3.02(c))):
  1-8 g from 0.5-2 in to 10-18 in; 5-25 g from 0.5-1 in to 6-12 in; 1-3 g from 0.5-2 in to
  10-18 in;
- tar_past_18: pine tar, 1-8 g from 1-4 in to 19-24 in: not an alteration, but not legal
  as it is (the bat must be cleaned; the expected status is not_altered).

Each draw is a ``RulebookChange``: the changes, and the truth a perfect inspection would
read (``RulebookChange.truth``): kind, legal, region_in, rule and the kind's reading
(added_mass_g, removed_mass_g, diameter_lost_in, ...).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np

from updating.inspect.kind_table import Kind, kind
from updating.model.local_change import LocalChange, section_factors
from updating.model.profile import Profile
from updating.model.units import IN_TO_M

RulebookKind = Literal["nails", "shaved", "flattened", "grooved", "wax", "pine_tar",
                       "grip_tape", "spray", "tar_past_18"]
"""The rulebook's changes of the nuisance-rich fleet (the module's table)."""
RULEBOOK_KINDS: tuple[RulebookKind, ...] = get_args(RulebookKind)
LEGAL_KINDS: tuple[RulebookKind, ...] = ("pine_tar", "grip_tape", "spray")
HANDLE_LIMIT_IN = 18.0
"""Rule 3.02(c): a grip substance may cover the handle up to this far from the knob, in."""
STEEL_KG_M3 = 7850.0
STEEL_E_PA = 200e9

TABLE_KIND = {"nails": "nailed", "shaved": "flat-surfaced", "flattened": "flat-surfaced",
              "grooved": "grooved", "wax": "coated", "pine_tar": "grip", "grip_tape": "grip",
              "spray": "grip", "tar_past_18": "grip_past"}
"""Each change's kind in the table of kinds (``updating.inspect.kind_table``): its finding
kind, rule words and legality (docs/contract.md, ``finding``)."""
SIZE = {"nails": ("net_added_mass_g", "g net"), "wax": ("added_mass_g", "g"),
        "shaved": ("removed_mass_g", "g removed"), "flattened": ("removed_mass_g", "g removed"),
        "grooved": ("removed_mass_g", "g removed")}
"""Each alteration's size for the detection limits (``updating.simulate.limits``): which
number of its truth's reading, and its unit."""


@dataclass(frozen=True)
class RulebookChange:
    """What was done to the bat, and what a perfect inspection would read.

    Attributes
    ----------
    kind : RulebookKind
        One of ``RULEBOOK_KINDS``.
    changes : tuple of LocalChange
        The section changes the virtual rig applies.
    region_in : tuple of float
        (start, end) of the changed stretch from the knob, in.
    reading : dict
        The kind's own numbers (added_mass_g, removed_mass_g, diameter_lost_in, ...).
    """

    kind: RulebookKind
    changes: tuple[LocalChange, ...]
    region_in: tuple[float, float]
    reading: dict

    @property
    def table_kind(self) -> Kind:
        """Return its kind in the table of kinds (``TABLE_KIND``)."""
        return kind(TABLE_KIND[self.kind])

    @property
    def finding_kind(self) -> str:
        """Return the contract's finding kind (inserted_mass, material_removed, ...)."""
        return self.table_kind.finding

    @property
    def altered(self) -> bool:
        """Return whether the rulebook calls this an alteration (a handle substance is not)."""
        return self.table_kind.alteration

    @property
    def legal(self) -> bool:
        """Return whether it is legal: a grip substance within 18 in of the knob."""
        return self.table_kind.legal

    def truth(self, integrity: str | None = None) -> dict:
        """Return the JSON-able truth, with the answer expected of the inspection.

        Parameters
        ----------
        integrity : str or None
            The case's data-integrity slip; any slip expects "inconclusive".

        Returns
        -------
        dict
            kind, altered, expected, region_in (null unless altered), the core keys (null),
            needs_cleaning and ``finding`` (kind, legal, region_in, rule, reading).
        """
        region = [round(v, 3) for v in self.region_in]
        expected = "inconclusive" if integrity else (
            "altered" if self.altered else "not_altered")
        return {"kind": self.kind, "altered": self.altered, "expected": expected,
                "region_in": region if self.altered else None, "core_diameter_in": None,
                "fill_density_ratio": None,
                "needs_cleaning": not self.altered and not self.legal,
                "finding": {"kind": self.finding_kind, "legal": self.legal,
                            "region_in": region, "rule": self.table_kind.rule,
                            "reading": {k: round(v, 4) for k, v in self.reading.items()}}}


def removed_mass_kg(profile: Profile, rho_kg_m3: float, change: LocalChange) -> float:
    """Return the wood a change's material removal takes off, kg.

    Parameters
    ----------
    profile : Profile
        The bat's outer profile.
    rho_kg_m3 : float
        The wood's density, kg/m^3.
    change : LocalChange
        The change (diameter loss and flat; the radial plane's area is every plane's).

    Returns
    -------
    float
        rho int pi/4 D^2 (1 - A'/A) dx over the change (trapezoid, 2001 points).
    """
    x = np.linspace(change.x0_m, change.x1_m, 2001)
    D = profile.diameter_at(x)
    area_f, _ = section_factors(D, change, "radial")
    return float(rho_kg_m3 * np.trapezoid(np.pi / 4 * D**2 * (1 - area_f), x))


def nails(rng: np.random.Generator, length_in: float, rho_kg_m3: float,
          min_plug_in: float) -> RulebookChange:
    """Draw 2-6 steel nails driven axially into the barrel end under a plug."""
    u = rng.uniform
    n, d_in, long_in = int(rng.integers(2, 7)), u(0.10, 0.16), u(2.0, 3.5)
    plug_in, bonded, offset_in = max(u(0.5, 1.0), min_plug_in), u(0.0, 0.2), u(0.2, 0.6)
    d_m, long_m, off_m = d_in * IN_TO_M, long_in * IN_TO_M, offset_in * IN_TO_M
    volume = n * np.pi / 4 * d_m**2 * long_m
    ei = bonded * n * STEEL_E_PA * (np.pi / 64 * d_m**4 + np.pi / 4 * d_m**2 * off_m**2)
    x1 = length_in - plug_in
    change = LocalChange((x1 - long_in) * IN_TO_M, x1 * IN_TO_M,
                         added_mass_kg=volume * (STEEL_KG_M3 - rho_kg_m3),
                         mass_at_surface=False, added_ei_n_m2=ei)
    reading = {"added_mass_g": 1e3 * volume * STEEL_KG_M3,
               "net_added_mass_g": 1e3 * change.added_mass_kg, "n_nails": n,
               "nail_diameter_in": d_in, "nail_length_in": long_in, "bonded_fraction": bonded}
    return RulebookChange("nails", (change,), (x1 - long_in, x1), reading)


def removal(rng: np.random.Generator, kind: RulebookKind, profile: Profile,
            rho_kg_m3: float) -> RulebookChange:
    """Draw a shaved or flattened barrel: 0.02-0.1 in over 4-14 in ending near the end."""
    u = rng.uniform
    length_in = profile.length_m / IN_TO_M
    cut_in, span_in = u(0.02, 0.10), u(4.0, 14.0)
    x1 = length_in - u(0.5, 2.0)
    x0 = x1 - span_in
    if kind == "shaved":
        change = LocalChange(x0 * IN_TO_M, x1 * IN_TO_M, diameter_loss_m=cut_in * IN_TO_M)
    else:
        change = LocalChange(x0 * IN_TO_M, x1 * IN_TO_M, flat_depth_m=cut_in * IN_TO_M,
                             flat_angle_deg=u(0.0, 180.0))
    reading = {"diameter_lost_in": cut_in, "length_in": span_in,
               "removed_mass_g": 1e3 * removed_mass_kg(profile, rho_kg_m3, change)}
    if kind == "flattened":
        reading["flat_angle_deg"] = change.flat_angle_deg
    return RulebookChange(kind, (change,), (x0, x1), reading)


def grooves(rng: np.random.Generator, profile: Profile, rho_kg_m3: float) -> RulebookChange:
    """Draw 3-8 rings 0.02-0.06 in deep and 0.1-0.25 in wide cut round the barrel."""
    u = rng.uniform
    length_in = profile.length_m / IN_TO_M
    n, depth_in, width_in = int(rng.integers(3, 9)), u(0.02, 0.06), u(0.10, 0.25)
    pitch_in = u(0.5, 1.5)
    starts = length_in - u(1.0, 3.0) - width_in - pitch_in * np.arange(n)[::-1]
    changes = tuple(LocalChange(a * IN_TO_M, (a + width_in) * IN_TO_M,
                                diameter_loss_m=2 * depth_in * IN_TO_M) for a in starts)
    removed = sum(removed_mass_kg(profile, rho_kg_m3, c) for c in changes)
    reading = {"diameter_lost_in": 2 * depth_in, "groove_depth_in": depth_in, "n_grooves": n,
               "groove_width_in": width_in, "removed_mass_g": 1e3 * removed}
    return RulebookChange("grooved", changes, (float(starts[0]), float(starts[-1] + width_in)),
                          reading)


def coating(
    kind: RulebookKind, mass_g: float, x0_in: float, x1_in: float, taper: float = 0.0,
    segments: int = 4,
) -> RulebookChange:
    """Return a surface substance of ``mass_g`` over [x0_in, x1_in] (mass, no stiffness).

    Parameters
    ----------
    kind : RulebookKind
        The substance's kind.
    mass_g : float
        Its whole mass, g.
    x0_in, x1_in : float
        The covered stretch from the knob, in.
    taper : float
        0: an even layer (one ``LocalChange``). t in (0, 1]: a layer thicker near the knob,
        its thickness falling linearly as 1 - t s over the stretch (s from 0 at ``x0_in`` to
        1 at ``x1_in``), as ``segments`` even layers whose masses follow the mean thickness
        of each (the handle's diameter taken as the same in each).
    segments : int
        The even layers of a tapered coat.

    Returns
    -------
    RulebookChange
        The coat; its reading is ``added_mass_g`` (and ``taper`` when not 0).
    """
    if taper == 0.0:
        change = LocalChange(x0_in * IN_TO_M, x1_in * IN_TO_M, added_mass_kg=1e-3 * mass_g)
        return RulebookChange(kind, (change,), (x0_in, x1_in), {"added_mass_g": mass_g})
    edges = np.linspace(0.0, 1.0, segments + 1)
    thickness = 1.0 - taper * 0.5 * (edges[:-1] + edges[1:])
    share = thickness / thickness.sum()
    x = x0_in + (x1_in - x0_in) * edges
    changes = tuple(LocalChange(a * IN_TO_M, b * IN_TO_M, added_mass_kg=1e-3 * mass_g * w)
                    for a, b, w in zip(x[:-1], x[1:], share, strict=True))
    return RulebookChange(kind, changes, (x0_in, x1_in),
                          {"added_mass_g": mass_g, "taper": taper})


def draw_change(
    rng: np.random.Generator, kind: RulebookKind, profile: Profile, rho_kg_m3: float,
    min_plug_in: float = 0.0,
) -> RulebookChange:
    """Draw a random change of ``kind`` (see the module's table) on a bat.

    Parameters
    ----------
    rng : Generator
        The random source.
    kind : RulebookKind
        One of ``RULEBOOK_KINDS``.
    profile : Profile
        The bat's true outer profile.
    rho_kg_m3 : float
        The wood's density, kg/m^3 (the wood nails' pilot holes and a cut remove).
    min_plug_in : float
        The shortest plug over nails (behind a cupped end), in.

    Returns
    -------
    RulebookChange
        The change and its truth.
    """
    u = rng.uniform
    length_in = profile.length_m / IN_TO_M
    if kind == "nails":
        return nails(rng, length_in, rho_kg_m3, min_plug_in)
    if kind in ("shaved", "flattened"):
        return removal(rng, kind, profile, rho_kg_m3)
    if kind == "grooved":
        return grooves(rng, profile, rho_kg_m3)
    if kind == "wax":
        return coating(kind, u(3.0, 15.0), length_in - u(10.0, 16.0), length_in)
    if kind == "pine_tar":
        return coating(kind, u(1.0, 8.0), u(0.5, 2.0), u(10.0, HANDLE_LIMIT_IN))
    if kind == "grip_tape":
        return coating(kind, u(5.0, 25.0), u(0.5, 1.0), u(6.0, 12.0))
    if kind == "spray":
        return coating(kind, u(1.0, 3.0), u(0.5, 2.0), u(10.0, HANDLE_LIMIT_IN))
    if kind == "tar_past_18":
        return coating(kind, u(1.0, 8.0), u(1.0, 4.0), u(HANDLE_LIMIT_IN + 1.0, 24.0))
    raise ValueError(f"unknown rulebook change {kind!r} (one of {', '.join(RULEBOOK_KINDS)})")
