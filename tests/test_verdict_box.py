"""The report's first screen (issue 50): at most 40 words, no statistics words, no hash or
option name, for every status, every kind of finding, both sources of the chance and every
kind of inconclusive reason."""

from __future__ import annotations

import itertools
import re

import pytest

from batlab.verdict_box import MAX_WORDS, REASON_KINDS, reason_kind, verdict_box, word_count

FORBIDDEN = re.compile(r"\bF\b|nominal|unmeasured|p-value|\b[0-9a-f]{10}\b|--|\$|\.json",
                       re.IGNORECASE)

NOMINAL = {"value": 1e-7, "source": "nominal", "calibration": None, "nominal": 1e-7,
           "model": "white-ash-34.0in-7f03ee6881",
           "unmeasured": "no calibration of bat model white-ash-34.0in-7f03ee6881 is stored"}
MEASURED = {"value": 0.0, "source": "calibration", "nominal": 1e-7,
            "calibration": {"model": "white-ash-34.0in-7f03ee6881", "n": 3000, "exceeding": 0,
                            "record_seq": 17}}
FINDINGS = {
    "filled": {"kind": "core", "rule": "filled", "legal": False, "region_in": [24.0, 33.0],
               "reading": {"core_diameter_in": 1.0, "fill_density_ratio": 0.3}},
    "hollowed": {"kind": "core", "rule": "hollowed", "legal": False, "region_in": [24.0, 33.0],
                 "reading": {"core_diameter_in": 1.0, "fill_density_ratio": 0.0}},
    "nailed": {"kind": "inserted_mass", "rule": "nailed", "legal": False,
               "region_in": [30.8, 33.8], "reading": {"added_mass_g": 18.2}},
    "coated": {"kind": "surface_coating", "rule": "covered with a substance", "legal": False,
               "region_in": [20.0, 30.0], "reading": {"added_mass_g": 13.0}},
    "shaved": {"kind": "material_removed", "rule": "flat-surfaced", "legal": False,
               "region_in": [26.0, 31.3],
               "reading": {"diameter_lost_in": 0.074, "removed_mass_g": 45.4}},
    "other": {"kind": "local_change", "rule": "altered or tampered with", "legal": False,
              "region_in": [10.0, 14.0], "reading": {"mass_change_pct": 4.0}},
}
GRIPS = {
    "grip": {"kind": "handle_substance", "rule": "grip substance (3.02(c))", "legal": True,
             "region_in": [1.0, 15.0], "reading": {"added_mass_g": 5.0}},
    "grip_past": {"kind": "handle_substance", "rule": "grip substance past 18 in (3.02(c))",
                  "legal": False, "region_in": [1.0, 20.0], "reading": {"added_mass_g": 9.0}},
}
REASONS = [[marks[0] + " something long with F 22.0 and --retest-meta retest.json"]
           for _, marks, _, _ in REASON_KINDS] + [["an odd refusal nobody listed"]]


def _cases():
    for (name, f), ch in itertools.product(FINDINGS.items(), (NOMINAL, MEASURED)):
        yield f"altered-{name}-{ch['source']}", {"status": "altered", "finding": f,
                                                  "chance": ch, "reasons": ["x"]}
    for (name, f), ch in itertools.product({**GRIPS, "clean": None}.items(),
                                           (NOMINAL, {**MEASURED, "value": 0.92})):
        yield f"clean-{name}-{ch['source']}", {"status": "not_altered", "finding": f,
                                                "chance": ch, "reasons": ["x"]}
    for reasons, f in itertools.product(REASONS, (None, FINDINGS["nailed"])):
        yield f"inconclusive-{reasons[0][:12]}-{bool(f)}", {
            "status": "inconclusive", "finding": f, "chance": None, "reasons": reasons}
    yield "legacy-altered", {"altered": True, "region_in": [24.0, 33.0],
                             "core_diameter_in": 1.0, "fill_density_ratio": 0.3,
                             "confidence": 0.9999}


@pytest.mark.parametrize("case", list(_cases()), ids=lambda c: c[0])
def test_first_screen_is_short_and_plain(case):
    _, v = case
    text = verdict_box(v).text()
    assert word_count(text) <= MAX_WORDS, text
    assert not FORBIDDEN.search(text), text


def test_first_screen_says_what_where_how_much_and_what_next():
    box = verdict_box({"status": "altered", "finding": FINDINGS["nailed"], "chance": MEASURED})
    assert box.verdict == "Altered: nailed."
    assert box.what == "about 18 g added, 31–34 in from the knob."
    assert box.sure == "None of 3,000 clean re-tests of this bat model differed this much."
    assert "X-ray" in box.next
    clean = verdict_box({"status": "not_altered", "finding": GRIPS["grip"], "chance": NOMINAL})
    assert clean.verdict == "Not altered." and "legal grip" in clean.what
    assert clean.next.startswith("None; the bat may be used")
    past = verdict_box({"status": "not_altered", "finding": GRIPS["grip_past"]})
    assert past.next.startswith("Clean it off past 18 in")


def test_inconclusive_reason_kinds():
    assert reason_kind(["too few modes pair (2 of 6): re-test with more hits"])[0] == "modes"
    assert reason_kind(["the test points cannot see the barrel (1 in ...)"])[0] == "barrel"
    assert reason_kind(["something new"])[0] == "other"
    box = verdict_box({"status": "inconclusive",
                       "reasons": ["too few modes pair (2 of 6): re-test with more hits"]})
    assert box.verdict == "No verdict: not called altered."
    assert box.next == "Re-test with more hits."


def test_a_weighed_bat_is_not_asked_to_be_weighed():
    """With the re-test's weight given, the next step does not ask for it (issue 50)."""
    v = {"status": "inconclusive", "reasons": ["the change fits nailed, but also fits the "
                                               "wood changed as far as it can"]}
    assert "weigh" in verdict_box(v).next.lower()
    assert "weigh" not in verdict_box(v, weighed=True).next.lower()


def test_terminal_says_the_chance_once():
    """The terminal's verdict does not repeat a chance clause its reason already holds (the
    demo printed it three times, issue 50)."""
    from batlab.formatting import chance_words, readable

    said = chance_words(NOMINAL)
    out = {"serial": "S", "status": "altered", "chance": NOMINAL,
           "reasons": [f"the change is not one moisture can make ({said})", "it fits a core"]}
    assert readable(out).count(said) == 1
    assert readable({**out, "reasons": ["it fits a core"]}).count(said) == 1
