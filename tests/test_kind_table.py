"""The table of kinds (issue 38): complete, consistent with the rulebook, and the one place a
kind is defined.

The simulator's every change has a kind in the table whose finding, rule words and
legality its truth carries; every kind a family's fit can read as is said, labelled and
coloured; a stretch of added mass is legal exactly when Rule 3.02(c) says; the fitted
parameters sit where their names say; and a kind added to the table at run time is read,
gated, said, labelled and coloured with no other edit.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from batlab.formatting import finding_words
from batlab.report import finding_label
from updating.inspect import kind_table
from updating.inspect.decision import Evidence, kind_supported
from updating.inspect.finding import describe, found
from updating.inspect.hypotheses import N_CORE, NULL_INDEX, NULL_NAMES, null_params
from updating.inspect.kind_table import (
    FAMILIES,
    KINDS,
    RULE_MAX_HANDLE_IN,
    Gate,
    Kind,
    kind,
    kind_of,
    lab_key,
    lab_values,
    read_kind,
)
from updating.inspect.kinds import N_PARAMS
from updating.inspect.local_change import N_SEGMENT, SegmentSpace
from updating.model.profile import paper_profile
from updating.model.units import IN_TO_M
from updating.simulate.rulebook import (
    LEGAL_KINDS,
    RULEBOOK_KINDS,
    SIZE,
    TABLE_KIND,
    coating,
    draw_change,
)

LENGTH_IN = 34.0


def sample_reading(k: Kind, rng: np.random.Generator) -> dict:
    """A plausible SI reading of kind ``k`` (each of its keys)."""
    return {key: float(rng.uniform(0.01, 0.5)) * (IN_TO_M if key.endswith("_m") else 1.0)
            for key in k.reading}


def contract(k: Kind, region_in: tuple[float, float], reading: dict) -> dict:
    """The contract's finding of kind ``k`` (lab units)."""
    return {"kind": k.finding, "legal": k.legal, "region_in": list(region_in), "rule": k.rule,
            "reading": lab_values(reading)}


def test_every_simulated_change_has_its_kind_and_the_truth_carries_it():
    assert set(TABLE_KIND) == set(RULEBOOK_KINDS)
    profile = paper_profile()
    for name in RULEBOOK_KINDS:
        k = kind(TABLE_KIND[name])
        assert k.legal == (name in LEGAL_KINDS), name
        change = draw_change(np.random.default_rng(3), name, profile, 650.0)
        truth = change.truth()
        f = truth["finding"]
        assert (f["kind"], f["rule"], f["legal"]) == (k.finding, k.rule, k.legal), name
        assert truth["altered"] == k.alteration
        assert (name in SIZE) == k.alteration  # every alteration has a detection-limit size
        if k.alteration:
            assert SIZE[name][0] in f["reading"]


def test_every_kind_is_said_labelled_and_coloured():
    rng = np.random.default_rng(5)
    for k in KINDS.values():
        assert k.family in FAMILIES, k.name
        reading = sample_reading(k, rng)
        if k.gate is not None:
            assert k.gate.key in k.reading and k.alteration
        region = (24.0, 30.0)
        f = found(k, (region[0] * IN_TO_M, region[1] * IN_TO_M), reading, {}, k.family)
        assert kind_of(f.kind, f.rule) is k
        said = describe(f)
        assert said and "{" not in said
        words = finding_words(contract(k, region, reading), LENGTH_IN)
        assert words and "{" not in words
        if k.alteration:
            assert f"{region[0]:.1f}-{region[1]:.1f} in" in said
        for status in ("altered", "not_altered", "inconclusive"):
            label, short, colour = finding_label(contract(k, region, reading), status)
            assert label and short and colour
            if not k.alteration:  # a grip says what it is whatever the verdict
                assert colour == k.colour
        # the kind's every reading key reaches the words in the lab's units
        assert all(lab_key(key) in contract(k, region, reading)["reading"] for key in k.reading)


def test_every_family_reads_as_a_kind_everywhere_along_the_bat():
    rng = np.random.default_rng(7)
    for family in FAMILIES:
        kinds = [k for k in KINDS.values() if k.family == family]
        assert kinds, family
        for _ in range(200):
            a = float(rng.uniform(0.0, LENGTH_IN - 0.5))
            b = float(rng.uniform(a + 0.5, LENGTH_IN))
            reading = {"fill_density_ratio": float(rng.uniform(0.0, 3.0))}
            assert read_kind(family, (a, b), LENGTH_IN, reading) in kinds


def test_family_parameter_counts_follow_the_table():
    assert N_PARAMS["core"] == N_CORE
    assert N_SEGMENT == N_PARAMS["local_change"] == 4
    assert set(NULL_INDEX) == set(NULL_NAMES) and sorted(NULL_INDEX.values()) == list(
        range(len(NULL_NAMES)))


@settings(max_examples=60, deadline=None)
@given(start=st.floats(0.5, 33.0), length=st.floats(0.5, 20.0))
def test_added_mass_is_legal_exactly_within_18_in_of_the_knob(start, length):
    end = min(start + length, LENGTH_IN)
    k = read_kind("added_mass", (start, end), LENGTH_IN, {})
    assert k.legal == (end <= RULE_MAX_HANDLE_IN + kind_table.HANDLE_SLACK_IN)
    if start > RULE_MAX_HANDLE_IN + kind_table.HANDLE_SLACK_IN:
        assert k.alteration  # nothing past the handle is a grip
    assert k.legal == (finding_label(contract(k, (start, end), {"added_mass_kg": 0.01}),
                                     "not_altered")[2] == kind_table.LEGAL_COLOUR)


@settings(max_examples=30, deadline=None)
@given(mass_g=st.floats(0.0, 120.0), start=st.floats(20.0, 30.0), length=st.floats(0.5, 4.0),
       loss_in=st.floats(0.0, 0.3))
def test_the_named_parameters_are_where_the_families_read_them(mass_g, start, length,
                                                                loss_in):
    profile = paper_profile()
    for family, amp, check in (
            ("added_mass", {"mass_g": mass_g},
             lambda s: s.added_mass_kg == pytest.approx(mass_g * 1e-3)),
            ("diameter_loss", {"loss_in": loss_in},
             lambda s: s.diameter_loss_m == pytest.approx(loss_in * IN_TO_M))):
        space = SegmentSpace(profile, None, family)
        x = np.zeros(space.index(FAMILIES[family].names[-1]) + 1)
        x[space.index("start_in")], x[space.index("length_in")] = start, length
        for name, v in amp.items():
            x[space.index(name)] = v
        seg = space.segment(x)
        assert seg.x0_m == pytest.approx(start * IN_TO_M) and check(seg)
        lo, hi = space.family_bounds()
        assert (lo <= hi).all() and len(lo) == len(FAMILIES[family].params)


def test_the_null_parameters_are_read_by_name():
    x = np.zeros(len(NULL_NAMES))
    x[NULL_INDEX["density_pct"]] = 2.0
    x[NULL_INDEX["sensor_mass_change_g"]] = 3.0
    x[NULL_INDEX["handle_substance_g"]] = 5.0
    x[NULL_INDEX["handle_substance_from_in"]] = 1.0
    x[NULL_INDEX["handle_substance_to_in"]] = 12.0
    p = null_params(x, 0.0)
    assert p.density_scale == pytest.approx(1.02)
    assert p.sensor_mass_change_kg == pytest.approx(3e-3)
    (grip,) = p.segments
    assert grip.added_mass_kg == pytest.approx(5e-3)
    assert (grip.x0_m, grip.x1_m) == pytest.approx((1.0 * IN_TO_M, 12.0 * IN_TO_M))


def test_a_kind_added_to_the_table_flows_everywhere(monkeypatch):
    """An end cap (foreign dense plug at the barrel end) added at run time, before nailed."""
    capped = Kind("capped", "inserted_mass", "added_mass", "filled", False, True,
                  lambda r, n, x: n - r[1] < 0.5 and r[1] - r[0] <= 1.5, ("added_mass_kg",),
                  Gate("added_mass_kg", 5.0),
                  "about {added_mass_g:.0f} g end cap at {where} ({rule})",
                  ("{rule}: an end cap of about {added_mass_g:.0f} g, {where}",),
                  label="end cap: {rule}", short="capped", colour="#123456")
    table = dict(KINDS)
    order = list(table)
    order.insert(order.index("nailed"), "capped")
    table["capped"] = capped
    monkeypatch.setattr(kind_table, "KINDS", {name: table[name] for name in order})

    k = read_kind("added_mass", (33.0, 34.0), LENGTH_IN, {})
    assert k is capped
    assert read_kind("added_mass", (28.0, 31.0), LENGTH_IN, {}).name == "nailed"
    f = found(k, (33.0 * IN_TO_M, 34.0 * IN_TO_M), {"added_mass_kg": 0.012},
              {"added_mass_kg": 0.001}, "added_mass")
    assert (f.kind, f.rule, f.legal) == ("inserted_mass", "filled", False)
    assert describe(f) == "about 12 g end cap at 33.0-34.0 in from the knob end (filled)"
    assert kind_supported(f)  # 12 - 2 g >= 5 g
    assert not kind_supported(replace(f, reading={"added_mass_kg": 0.006}))
    evidence = Evidence(F=20.0, p_value=1e-6, significant=True, large=True, finding=f,
                        finding_text=describe(f), held_null=(), held_core=(), dlnw=None)
    assert evidence.named and evidence.supported and not evidence.grip_kind
    d = contract(k, (33.0, 34.0), f.reading)
    assert finding_words(d, LENGTH_IN) == (
        "filled: an end cap of about 12 g, the last 1 in of the barrel (33.0-34.0 in)")
    assert finding_label(d, "altered") == ("end cap: filled", "capped", "#123456")
    assert finding_label(d, "inconclusive")[:2] == ("end cap: filled (no verdict)", "capped?")


def test_the_hollow_threshold_is_one_number():
    """The words follow the rule: a fill under HOLLOW_MAX_FILL is hollowed and said hollow."""
    for fill in (0.0, 0.07, 0.099, 0.1, 0.3):
        k = read_kind("core", (24.0, 30.0), LENGTH_IN, {"fill_density_ratio": fill})
        reading = {"core_diameter_m": 0.025, "fill_density_ratio": fill}
        words = finding_words(contract(k, (24.0, 30.0), reading))
        assert (k.rule == "hollowed") == (fill < kind_table.HOLLOW_MAX_FILL)
        assert ("left hollow" in words) == (k.rule == "hollowed")


def test_a_coat_drawn_by_hand_carries_its_kind():
    change = coating("wax", 8.0, 20.0, 34.0)
    assert change.finding_kind == kind("coated").finding and change.altered
