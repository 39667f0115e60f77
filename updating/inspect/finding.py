"""What changed, in the rulebook's words: the kind of a local change and its reading.

The families fitted beside the generic local change (``local_change``) say what the change
is by its physics (../../docs/inspection.md, "The kinds and their signatures"):

- a core (``hypotheses.fit_core``), from the barrel end: ``core``, "filled" ("hollowed" when
  its fill is under ``HOLLOW_MAX_FILL`` of the wood's density);
- added mass within 18 in of the knob: ``handle_substance``, "grip substance (3.02(c))",
  legal;
- added mass from within ``HANDLE_START_MAX_IN`` of the knob past 18 in:
  ``handle_substance``, not legal as it is [1];
- added mass elsewhere, up to ``INSERT_MAX_IN`` long: ``inserted_mass``, "nailed"; longer:
  ``surface_coating``, "covered with a substance";
- a diameter loss ``GROOVE_MAX_IN`` long or more: ``material_removed``, "flat-surfaced";
  shorter: "grooved";
- none of them as well as the generic change: ``local_change``, "altered or tampered with".

[1] not an alteration: the bat must be cleaned before play, the verdict stays not altered.

A family is chosen by Akaike's criterion on the weighted residual, RSS / s^2 + 2 k (k its
parameters, s^2 the generic fit's residual variance per datum, at least 1); the generic
change is named only when every kind is worse than it by more than ``KIND_MARGIN``.

A core filled more than ``HEAVY_FILL_RATIO`` times as densely as the wood is no wood and no
cork: a hole full of something heavy adds mass and, when it is too thin to be surely a
practical core, almost no stiffness, which is what the added-mass family describes with two
fewer parameters. When that family scores within ``KIND_TIE`` of such a core (Akaike
differences under about 4 leave both "substantially supported"; Burnham and Anderson,
*Model Selection and Multimodel Inference*, 2nd ed., 2002, sec. 2.6), the change is read as
added mass, in grams (``prefer_added_mass``): nails or a coat, not a thin core whose
diameter the data cannot fix. A dense plug in a wide hole (a practical core) stays a core.
"""

from __future__ import annotations

from dataclasses import dataclass, field

RULE_MAX_HANDLE_IN = 18.0
"""Rule 3.02(c): the handle, for not more than 18 in from its end, may be treated for grip."""
HANDLE_SLACK_IN = 0.5
"""A grip substance's fitted reach may pass 18 in by this much before it is said to."""
HANDLE_START_MAX_IN = 8.0
"""Added mass that starts this close to the knob and reaches past 18 in is a grip substance
spread too far (clean the bat), not a coat of the barrel (which starts past the handle)."""
INSERT_MAX_IN = 6.0
"""Longest stretch of added mass read as an insert (nails 2-3.5 in, a dense end plug 2-4 in,
as fitted: up to about 5 in) rather than a coat (wax over the last 10-16 in)."""
GROOVE_MAX_IN = 2.0
"""Shortest stretch of lost diameter read as flat-surfaced rather than grooved."""
HOLLOW_MAX_FILL = 0.1
"""A core whose fill is lighter than this share of the wood is read as hollowed."""
KIND_MARGIN = 10.0
"""Akaike score by which every kind must trail the generic change for ``local_change``."""
HEAVY_FILL_RATIO = 2.0
"""A core's fill/wood density ratio above which the fill is heavier than any bat wood
(about 0.4-0.75 g/cm^3; the densest woods reach 1.2): metal, or mass standing for a thin core."""
KIND_TIE = 4.0
"""Akaike difference within which two families are both supported (module docstring)."""

RULES = {
    "filled": "filled",
    "hollowed": "hollowed",
    "nailed": "nailed",
    "flat-surfaced": "flat-surfaced",
    "grooved": "grooved",
    "coated": "covered with a substance",
    "grip": "grip substance (3.02(c))",
    "grip_past": "grip substance past 18 in (3.02(c))",
    "other": "altered or tampered with",
}
"""The rulebook's words for each finding (contract ``finding.rule``)."""


@dataclass(frozen=True)
class Finding:
    """What changed between the tests, in the rulebook's words.

    Parameters
    ----------
    kind : str
        ``core``, ``inserted_mass``, ``material_removed``, ``surface_coating``,
        ``handle_substance`` or ``local_change``.
    legal : bool
        True only for a grip substance within 18 in of the knob (Rule 3.02(c)).
    region_m : tuple of float
        Where, m from the knob end.
    rule : str
        The rule's word (``RULES``).
    reading : dict
        The kind's numbers, SI (``added_mass_kg``, ``diameter_lost_m``, ``removed_mass_kg``,
        ``core_diameter_m``, ``fill_density_ratio``, ``mass_change_rel``,
        ``stiffness_change_rel``).
    uncertainty : dict
        Their standard uncertainties (1 sigma), same keys and units, and the region's
        (``region_start_m``).
    family : str
        The fitted family it was read from.
    """

    kind: str
    legal: bool
    region_m: tuple[float, float]
    rule: str
    reading: dict = field(default_factory=dict)
    uncertainty: dict = field(default_factory=dict)
    family: str = ""

    @property
    def past_handle(self) -> bool:
        """A grip substance that reaches past 18 in (clean the bat; not an alteration)."""
        return self.kind == "handle_substance" and not self.legal


def added_mass_kind(region_in: tuple[float, float]) -> tuple[str, str, bool]:
    """(kind, rule key, legal) of an added mass over ``region_in`` (in from the knob end)."""
    start_in, end_in = region_in
    if end_in <= RULE_MAX_HANDLE_IN + HANDLE_SLACK_IN:
        return "handle_substance", "grip", True
    if start_in <= HANDLE_START_MAX_IN:
        return "handle_substance", "grip_past", False
    if end_in - start_in <= INSERT_MAX_IN:
        return "inserted_mass", "nailed", False
    return "surface_coating", "coated", False


def diameter_loss_rule(region_in: tuple[float, float]) -> str:
    """Rule key of a diameter loss over ``region_in``: flat-surfaced, or grooved when short."""
    return "flat-surfaced" if region_in[1] - region_in[0] >= GROOVE_MAX_IN else "grooved"


def core_rule(fill_density_ratio: float) -> str:
    """Rule key of a core: hollowed when (nearly) empty, else filled."""
    return "hollowed" if fill_density_ratio < HOLLOW_MAX_FILL else "filled"


def akaike(rss: float, n_params: int, s2: float) -> float:
    """Akaike's score of a fit: RSS / s^2 + 2 k."""
    return rss / s2 + 2.0 * n_params


def choose_family(scores: dict[str, float], generic_score: float) -> str:
    """Choose the family with the lowest score.

    ``local_change`` when every one trails the generic change by more than ``KIND_MARGIN``.
    """
    best = min(scores, key=scores.get)
    return "local_change" if scores[best] - generic_score > KIND_MARGIN else best


def prefer_added_mass(core_fill_ratio: float, practical_core: bool,
                      scores: dict[str, float]) -> bool:
    """Tell whether a core chosen by its score is better read as added mass.

    Parameters
    ----------
    core_fill_ratio : float
        The core's mean fill/wood density ratio.
    practical_core : bool
        Whether its diameter, less two standard uncertainties, makes a practical core.
    scores : dict
        Family name -> Akaike score (``core`` and ``added_mass`` among them).

    Returns
    -------
    bool
        True when the fill is heavier than ``HEAVY_FILL_RATIO`` times the wood, the core
        is not surely practical and the added-mass family scores within ``KIND_TIE`` of it
        (module docstring).
    """
    return (core_fill_ratio > HEAVY_FILL_RATIO and not practical_core
            and scores["added_mass"] - scores["core"] <= KIND_TIE)


def describe(f: Finding) -> str:
    """Say a finding in the lab's words: what, how much and where (inches from the knob).

    Parameters
    ----------
    f : Finding
        The finding.

    Returns
    -------
    str
        E.g. "about 18 g of metal in 29.2-32.5 in from the knob end (nailed)".
    """
    a, b = (v / 0.0254 for v in f.region_m)
    where = f"{a:.1f}-{b:.1f} in from the knob end"
    r = f.reading
    if f.kind == "core":
        return (f"a core {r['core_diameter_m'] / 0.0254:.2f} in across at {where}, fill/wood "
                f"density {r['fill_density_ratio']:.2f} ({f.rule})")
    if f.kind == "inserted_mass":
        return f"about {1e3 * r['added_mass_kg']:.0f} g of metal in {where} ({f.rule})"
    if f.kind == "surface_coating":
        return f"about {1e3 * r['added_mass_kg']:.0f} g of a substance over {where} ({f.rule})"
    if f.kind == "handle_substance":
        return f"about {1e3 * r['added_mass_kg']:.0f} g added on the handle, {a:.0f}-{b:.0f} in"
    if f.kind == "material_removed":
        return (f"{r['diameter_lost_m'] / 0.0254:.3f} in of diameter removed over {where}, "
                f"about {1e3 * r['removed_mass_kg']:.0f} g of wood ({f.rule})")
    return (f"a local change of mass {100 * r['mass_change_rel']:+.0f} % and bending stiffness "
            f"{100 * r['stiffness_change_rel']:+.0f} % over {where}")
