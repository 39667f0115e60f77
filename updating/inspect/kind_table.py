"""One table of kinds: every change batlab names, what it fits and how it is said.

As ``scipy.signal`` keeps its windows (a table and one lookup), this module keeps the kinds
of change: ``FAMILIES``, the fitted families with their parameters and bounds, and
``KINDS``, each kind read from a family with its reading, its gate, the rule's words,
whether it is legal and its report label and colour; ``kind(name)`` looks one up,
``kind_of`` the kind of a finding (contract ``finding.kind`` and ``finding.rule``) and
``read_kind`` the kind a family's fit reads as. Every other place asks the table
(../../docs/kinds.md, "The table of kinds").

A family's fit reads as the first kind of that family, in the table's order, whose
``reads`` holds for the fitted stretch (in from the knob end), the bat's length and the
reading (SI):

- a core from the barrel end: "filled", or "hollowed" when its fill is under
  ``HOLLOW_MAX_FILL`` of the wood's density;
- added mass within 18 in of the knob (``RULE_MAX_HANDLE_IN`` + ``HANDLE_SLACK_IN``): a
  grip substance, legal (Rule 3.02(c)); from within ``HANDLE_START_MAX_IN`` of the knob
  past 18 in: a grip substance past 18 in, not legal as it is but not an alteration (the
  bat must be cleaned); elsewhere up to ``INSERT_MAX_IN`` long: nailed; longer: covered
  with a substance;
- a diameter loss ``GROOVE_MAX_IN`` long or more: flat-surfaced; shorter: grooved;
- the generic local change: "altered or tampered with".

Adding a kind: one ``Kind`` in ``KINDS`` (of an existing family, placed before the kinds
it carves its stretches from) and its draw in the simulator
(``updating.simulate.rulebook``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from updating.model.units import IN_TO_M

# --- the families ----------------------------------------------------------------------------

MIN_LENGTH_IN, MAX_LENGTH_IN = 0.5, 24.0
"""Shortest and longest stretch a segment family fits (a groove to a coat over the barrel,
or a grip substance from the knob past 18 in)."""
REL_MAX = 0.6
"""Largest relative change of the wood's mass or stiffness in the stretch (a 1.25 in core
removes 26 % of a 2.45 in barrel's section, a hollowed one half of its mass)."""
MASS_MAX_G = 120.0
"""Most mass a stretch may gain, g (six 10 g nails and a cap, or a thick coat)."""
LOSS_MAX_IN = 0.3
"""Most outer diameter a stretch may lose, in (a barrel shaved flat on one side)."""


@dataclass(frozen=True)
class Param:
    """One parameter of a family's part of x.

    Attributes
    ----------
    name : str
        Its name, units in it.
    lower, upper : float or None
        Its bounds; None where the family's own model sets them (a stretch's start ends
        ``MIN_LENGTH_IN`` short of the bat's end; a core's, ``hypotheses.CORE_LOWER``).
    """

    name: str
    lower: float | None = None
    upper: float | None = None


@dataclass(frozen=True)
class Family:
    """A fitted family: its parameters after the null's, and the scan's unit amplitudes.

    Attributes
    ----------
    name : str
        ``core``, ``added_mass``, ``diameter_loss`` or ``local_change``.
    params : tuple of Param
        Its parameters, in their order in x after the null's ``N_NULL``.
    scan_unit : tuple of float
        A segment family's unit amplitudes whose responses the scan combines
        (``local_change.segment_scan``); empty for the core.
    """

    name: str
    params: tuple[Param, ...]
    scan_unit: tuple[float, ...] = ()

    @property
    def names(self) -> tuple[str, ...]:
        """The parameters' names, in order."""
        return tuple(p.name for p in self.params)

    def index(self, name: str) -> int:
        """Return where parameter ``name`` sits in the family's part of x."""
        return self.names.index(name)

    def bounds(self, length_in: float) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) of a segment family's part of x on a bat ``length_in`` long."""
        top = length_in - MIN_LENGTH_IN
        return (np.array([p.lower for p in self.params], dtype=float),
                np.array([top if p.upper is None else p.upper for p in self.params],
                         dtype=float))


_STRETCH = (Param("start_in", 0.0, None), Param("length_in", MIN_LENGTH_IN, MAX_LENGTH_IN))

FAMILIES = {f.name: f for f in (
    Family("core", (Param("plug_in"), Param("length_in"), Param("fill_p"), Param("wood_q"))),
    Family("local_change", (*_STRETCH, Param("mass_rel", -REL_MAX, REL_MAX),
                            Param("stiffness_rel", -REL_MAX, REL_MAX)), (0.05, 0.05)),
    Family("added_mass", (*_STRETCH, Param("mass_g", 0.0, MASS_MAX_G)), (10.0,)),
    Family("diameter_loss", (*_STRETCH, Param("loss_in", 0.0, LOSS_MAX_IN)), (0.05,)),
)}
"""The fitted families (``hypotheses.fit_core``, ``local_change``): the core's parameters
are plug and filled length (in) and b = (d / 1 in)^2 split as fill_p = r b and
wood_q = (R_MAX - r) b (``hypotheses.ParamSpace.to_x``)."""
SEGMENT_FAMILIES = ("local_change", "added_mass", "diameter_loss")
"""The families of one stretch of the bat (``local_change.SegmentSpace``)."""

# --- the kinds -------------------------------------------------------------------------------

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
"""A core whose fill is lighter than this share of the wood is read as hollowed (and said
"left hollow"; the report's 0.05 before issue 38 disagreed with the rule word)."""

MIN_CORE_DIAMETER_IN = 0.30
"""Physical floor: the fitted core's diameter, less two standard uncertainties, must reach
this for "altered" (reported holes are 0.75-1.25 in, the smallest considered 0.5 in); a
significant change that only a thinner or undetermined core explains is model error or
drift, not a core. Calibrated with the two-plane shapes and the per-point shape noise
(sixth round, docs/inspection.md) on 320 nuisance-rich clean bats (seeds 600-639,
3000-3039, 7000-7119, 8000-8119; validated on 9000-9119): clean bats whose F passed the
floor reached 0.18 in; altered bats' candidates 0.33 in and more. Under issue 24's H1 the
288 clean and gripped inspections reached 0.24 in, and 0.43 in on one grip-tape bat at F 7.0,
below the F floor of 9 then in use."""
MIN_ADDED_MASS_G = 2.0
"""Added mass (an insert, a coat), less two standard uncertainties, that an alteration needs:
about half a nail. On the 288 clean and gripped inspections the largest such reading off the
handle was 0.6 g (a grip spread past 18 in, read beside H0's grip, aside: that is the grip's,
``nested._as_grip``); 3 g before."""
MIN_DIAMETER_LOST_IN = 0.01
"""Outer diameter lost, less two standard uncertainties, that an alteration needs (caliper
noise and sanding are thousandths of an inch; the 288 clean and gripped inspections reached
0.006 in)."""

ALTERED_COLOUR, LEGAL_COLOUR, OTHER_COLOUR = "C3", "#27ae60", "#d4a017"
"""Shading of a finding's region in the report: an alteration, a legal grip, anything else
(no verdict, or a grip past 18 in: clean the bat)."""


@dataclass(frozen=True)
class Gate:
    """How large a kind's reading must be, less two standard uncertainties, to alter a bat.

    Attributes
    ----------
    key : str
        The reading (SI, ``Finding.reading``).
    minimum : float
        Its floor in the lab's units (``lab_value``).
    """

    key: str
    minimum: float

    def passed(self, reading: dict, uncertainty: dict) -> bool:
        """Whether the reading less two standard uncertainties reaches the floor."""
        low = reading[self.key] - 2 * uncertainty.get(self.key, np.inf)
        return lab_value(self.key, low) >= self.minimum


Where = Callable[[tuple[float, float], float, dict], bool]
"""``reads(region_in, length_in, reading)``: whether a family's fit is this kind."""


def _always(region_in: tuple[float, float], length_in: float, reading: dict) -> bool:
    return True


@dataclass(frozen=True)
class Kind:
    """One kind of change: what it is read from, and how it is judged and said.

    Attributes
    ----------
    name : str
        The table's key.
    finding : str
        The contract's ``finding.kind`` (docs/contract.md).
    family : str
        The fitted family it is read from (``FAMILIES``; ``calipers`` for the caliper
        profile's removals, which ``caliper_verdict`` reads as the material_removed kinds).
    rule : str
        The rulebook's words (contract ``finding.rule``).
    legal : bool
        Legal as it is (a grip substance within 18 in of the knob, Rule 3.02(c)).
    alteration : bool
        An alteration when large enough (False: a grip substance, legal or to be cleaned).
    reads : callable
        ``reads(region_in, length_in, reading)``: whether a fit of its family is this kind
        (the first of the family's kinds, in the table's order, that holds).
    reading : tuple of str
        Its reading's keys, SI (``Finding.reading``; the contract's in lab units).
    gate : Gate or None
        What alters a bat; None: never by itself (a grip, a change of no named kind).
    says : str
        The lab's words (``finding.describe``, the verdict's reasons): a format string of
        the reading in lab units (``lab_values``), ``where``, ``a``, ``b`` (in from the
        knob end) and ``rule``.
    words : tuple of str
        The report's clause (``batlab.formatting.finding_words``): format strings of the
        contract's finding (its reading, ``where``, ``a``, ``b``, ``length_in``, ``rule``),
        joined; a part whose number the finding lacks is left out.
    label, short : str
        The report's legend label and short words (``batlab.report.finding_label``),
        format strings of ``rule``; an alteration's carry " (no verdict)" and "?" when
        the verdict is not altered.
    colour : str
        The report's shading of its region (an alteration's when altered).
    """

    name: str
    finding: str
    family: str
    rule: str
    legal: bool
    alteration: bool
    reads: Where
    reading: tuple[str, ...]
    gate: Gate | None
    says: str
    words: tuple[str, ...]
    label: str = "finding region: {rule}"
    short: str = "{rule}"
    colour: str = ALTERED_COLOUR


_CORE = dict(finding="core", family="core", legal=False, alteration=True,
             reading=("core_diameter_m", "fill_density_ratio"),
             gate=Gate("core_diameter_m", MIN_CORE_DIAMETER_IN),
             says="a core {core_diameter_in:.2f} in across at {where}, fill/wood density "
                  "{fill_density_ratio:.2f} ({rule})")
_BORE = "{rule}: a bore about {core_diameter_in:.2f} in across and {length_in:.1f} in long"
_ADDED = ("added_mass_kg",)
_MASS_GATE = Gate("added_mass_kg", MIN_ADDED_MASS_G)
_HANDLE = "about {added_mass_g:.0f} g added on the handle, {a:.0f}-{b:.0f} in"
_GRIP = dict(finding="handle_substance", family="added_mass", alteration=False, reading=_ADDED,
             gate=None, says=_HANDLE)
_REMOVED = dict(finding="material_removed", family="diameter_loss", legal=False, alteration=True,
                reading=("diameter_lost_m", "removed_mass_kg"),
                gate=Gate("diameter_lost_m", MIN_DIAMETER_LOST_IN),
                says="{diameter_lost_in:.3f} in of diameter removed over {where}, about "
                     "{removed_mass_g:.0f} g of wood ({rule})",
                words=("{rule}: about {diameter_lost_in:.3f} in of the diameter removed along "
                       "{length_in:.1f} in, {where}",))

KINDS = {k.name: k for k in (
    Kind("filled", rule="filled",
         reads=lambda r, n, x: not x["fill_density_ratio"] < HOLLOW_MAX_FILL,
         words=(_BORE, ", filled with material about {fill_density_ratio:.2f} times as dense "
                       "as the wood", ", in {where}"), **_CORE),
    Kind("hollowed", rule="hollowed", reads=_always,
         words=(_BORE, ", left hollow", ", in {where}"), **_CORE),
    Kind("grip", rule="grip substance (3.02(c))", legal=True,
         reads=lambda r, n, x: r[1] <= RULE_MAX_HANDLE_IN + HANDLE_SLACK_IN,
         words=(_HANDLE, ": grip substance, legal under Rule 3.02(c)"),
         label="legal grip (Rule 3.02(c))", short="legal grip", colour=LEGAL_COLOUR, **_GRIP),
    Kind("grip_past", rule="grip substance past 18 in (3.02(c))", legal=False,
         reads=lambda r, n, x: r[0] <= HANDLE_START_MAX_IN,
         words=(_HANDLE, ": a grip substance past 18 in; the bat must be cleaned before play"),
         label="grip past 18 in: clean the bat", short="grip past 18 in", colour=OTHER_COLOUR,
         **_GRIP),
    Kind("nailed", "inserted_mass", "added_mass", "nailed", False, True,
         lambda r, n, x: r[1] - r[0] <= INSERT_MAX_IN, _ADDED, _MASS_GATE,
         "about {added_mass_g:.0f} g of metal in {where} ({rule})",
         ("{rule}: about {added_mass_g:.0f} g of metal in {where}",)),
    Kind("coated", "surface_coating", "added_mass", "covered with a substance", False, True,
         _always, _ADDED, _MASS_GATE,
         "about {added_mass_g:.0f} g of a substance over {where} ({rule})",
         ("{rule}: about {added_mass_g:.0f} g of a substance over {where}",)),
    Kind("flat-surfaced", rule="flat-surfaced",
         reads=lambda r, n, x: r[1] - r[0] >= GROOVE_MAX_IN, **_REMOVED),
    Kind("grooved", rule="grooved", reads=_always, **_REMOVED),
    Kind("other", "local_change", "local_change", "altered or tampered with", False, True,
         _always, ("mass_change_rel", "stiffness_change_rel"), None,
         "a local change of mass {mass_change_pct:+.0f} % and bending stiffness "
         "{stiffness_change_pct:+.0f} % over {where}",
         ("a local change no alteration explains, over {where}",)),
)}
"""The kinds, in the order a family's fit is read (module docstring)."""
UNEXPLAINED = "other"
"""The kind of a change no named kind explains (the generic local change's)."""


def kind(name: str) -> Kind:
    """Return the kind ``name`` of ``KINDS``."""
    try:
        return KINDS[name]
    except KeyError:
        raise ValueError(f"unknown kind {name!r} (one of {', '.join(KINDS)})") from None


def kind_of(finding_kind: str, rule: str | None = None) -> Kind | None:
    """Return the kind of a finding: its contract kind and rule words.

    The kind with both; else the first with the contract kind (a record written before the
    rule words, or with other words); None when no kind has it.
    """
    same = [k for k in KINDS.values() if k.finding == finding_kind]
    return next((k for k in same if k.rule == rule), same[0] if same else None)


def read_kind(family: str, region_in: tuple[float, float], length_in: float,
              reading: dict) -> Kind:
    """Return the kind a fit of ``family`` reads as (the first whose ``reads`` holds)."""
    return next(k for k in KINDS.values()
                if k.family == family and k.reads(region_in, length_in, reading))


def lab_value(key: str, value: float) -> float:
    """Return an SI reading in the lab's units: *_m in in, *_kg in g, *_rel in %, else as it is."""
    if key.endswith("_m"):
        return value / IN_TO_M
    if key.endswith("_kg"):
        return 1e3 * value
    if key.endswith("_rel"):
        return 100 * value
    return value


def lab_key(key: str) -> str:
    """Return the lab's name of an SI reading's key (*_m -> *_in, *_kg -> *_g, *_rel -> *_pct)."""
    for si, lab in (("_m", "_in"), ("_kg", "_g"), ("_rel", "_pct")):
        if key.endswith(si):
            return key[: -len(si)] + lab
    return key


def lab_values(reading: dict) -> dict:
    """Return an SI reading in the lab's names and units (``lab_value``, unrounded)."""
    return {lab_key(k): lab_value(k, v) for k, v in reading.items()}


def say_parts(parts: tuple[str, ...], values: dict) -> str:
    """Join the format strings ``parts`` with ``values``, leaving out any it lacks a key of."""
    out = []
    for part in parts:
        try:
            out.append(part.format_map(values))
        except KeyError:
            continue
    return "".join(out)
