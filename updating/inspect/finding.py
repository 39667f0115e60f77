"""What changed, in the rulebook's words: the kind of a local change and its reading.

The families fitted beside the generic local change (``local_change``) say what the change
is by its physics (../../docs/kinds.md, "The kinds and their signatures"); which kind a
family's fit reads as, its rule words and whether it is legal are the table of kinds'
(``kind_table``).

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

from updating.inspect.kind_table import Kind, kind, kind_of, lab_values
from updating.model.units import IN_TO_M

KIND_MARGIN = 10.0
"""Akaike score by which every kind must trail the generic change for ``local_change``."""
HEAVY_FILL_RATIO = 2.0
"""A core's fill/wood density ratio above which the fill is heavier than any bat wood
(about 0.4-0.75 g/cm^3; the densest woods reach 1.2): metal, or mass standing for a thin core."""
KIND_TIE = 4.0
"""Akaike difference within which two families are both supported (module docstring)."""


@dataclass(frozen=True)
class Finding:
    """What changed between the tests, in the rulebook's words.

    Parameters
    ----------
    kind : str
        The contract's kind (``kind_table.Kind.finding``): ``core``, ``inserted_mass``,
        ``material_removed``, ``surface_coating``, ``handle_substance`` or ``local_change``.
    legal : bool
        True only for a grip substance within 18 in of the knob (Rule 3.02(c)).
    region_m : tuple of float
        Where, m from the knob end.
    rule : str
        The rule's words (``kind_table.Kind.rule``).
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


def found(k: Kind, region_m: tuple[float, float], reading: dict, uncertainty: dict,
          family: str) -> Finding:
    """Return a finding of kind ``k`` (its contract kind, legality and rule words)."""
    return Finding(k.finding, k.legal, region_m, k.rule, reading, uncertainty, family)


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
        E.g. "about 18 g of metal in 29.2-32.5 in from the knob end (nailed)": its kind's
        ``says`` (``kind_table``); a change of no kind in the table is said as ``other``.
    """
    a, b = (v / IN_TO_M for v in f.region_m)
    k = kind_of(f.kind, f.rule) or kind("other")
    return k.says.format_map({**lab_values(f.reading), "rule": f.rule, "a": a, "b": b,
                              "where": f"{a:.1f}-{b:.1f} in from the knob end"})
