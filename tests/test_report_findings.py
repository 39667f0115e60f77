"""The report speaks of what the verdict found (the rulebook's kinds, issue 24).

Each verdict is drawn at random (where, how much, each element's factors and signs): the
element figure must colour every bar by its sign, shade the finding's region with its kind in
the legend and mark it on the drawing of the bat; the headline must say the rule's word with
the reading.
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from batlab import pipeline
from batlab.report import element_figure, headline
from tests.inspect_standins import use_standins

SAMPLE = Path("data_samples/smooth_bat")

# kind -> (status, rule, legal, reading keys and their ranges, region length range in)
KINDS = {
    "core": ("altered", "filled", False,
             {"core_diameter_in": (0.6, 1.1), "fill_density_ratio": (0.2, 0.6)}, (6, 10)),
    "inserted_mass": ("altered", "nailed", False, {"added_mass_g": (9, 27)}, (2, 4)),
    "surface_coating": ("altered", "covered with a substance", False,
                        {"added_mass_g": (4, 15)}, (10, 15)),
    "material_removed": ("altered", "flat-surfaced", False,
                         {"diameter_lost_in": (0.03, 0.1), "removed_mass_g": (3, 20)}, (4, 10)),
    "handle_substance": ("not_altered", "grip substance (3.02(c))", True,
                         {"added_mass_g": (2, 30)}, (8, 14)),
    "grip_past": ("not_altered", "grip substance past 18 in (3.02(c))", False,
                  {"added_mass_g": (10, 40)}, (19, 22)),
    "local_change": ("inconclusive", "altered or tampered with", False,
                     {"mass_change_pct": (-20, 20), "stiffness_change_pct": (-20, 20)}, (3, 8)),
}


@pytest.fixture(scope="module")
def base():
    """The sample bat's report inputs (stand-in numerics), to be given drawn verdicts."""
    with pytest.MonkeyPatch.context() as mp:
        use_standins(mp)
        res = pipeline.inspect_files(SAMPLE / "profile.csv", SAMPLE / "meta.json",
                                     SAMPLE / "baseline.uff", SAMPLE / "retest_corked.uff")
    return pipeline.report_inputs(res, pipeline.read_meta_dict(SAMPLE / "meta.json"), {})


def drawn(base, name: str, seed: int):
    """Return report inputs with a random verdict of ``name``'s kind and its finding.

    Region, reading, the element factors (random signs) and an MSSO map with its noise are
    drawn; a handle substance starts near the knob, everything else ends at the barrel.
    """
    rng = np.random.default_rng(seed)
    status, rule, legal, ranges, span = KINDS[name]
    length_in = base.profile.length_m / 0.0254
    size = rng.uniform(*span)
    start = rng.uniform(0.5, 2.0) if name in ("handle_substance", "grip_past") else \
        length_in - size - rng.uniform(0.0, 1.0)
    region = [round(start, 2), round(start + size, 2)]
    reading = {k: float(rng.uniform(*r)) for k, r in ranges.items()}
    els = [dict(e) for e in base.verdict["elements"]]
    n = len(els)
    alpha, beta = rng.normal(0, 0.06, n), rng.normal(0, 0.06, n)
    for e, a, b in zip(els, alpha, beta, strict=True):
        e["alpha"], e["beta"] = float(a), float(b)
    std = rng.uniform(0.005, 0.03, n)
    msso = {"alpha": list(rng.normal(0, 0.05, n)), "beta": list(rng.normal(0, 0.05, n)),
            "alpha_std": list(std), "beta_std": list(std), "region_m": None}
    core = name == "core"
    verdict = {
        **base.verdict, "status": status,
        "altered": {"altered": True, "not_altered": False}.get(status),
        "reasons": ["drawn for the test"],
        "region_in": region if status == "altered" else None,
        "core_diameter_in": reading.get("core_diameter_in") if core else None,
        "fill_density_ratio": reading.get("fill_density_ratio") if core else None,
        "finding": {"kind": "handle_substance" if name == "grip_past" else name,
                    "legal": legal, "region_in": region, "rule": rule, "reading": reading,
                    "uncertainty": {}},
        "elements": els,
        "details": {"p_value": 1e-5 if status == "altered" else 0.4, "statistic": "F",
                    "n_modes": 6, "msso": msso},
    }
    return replace(base, verdict=verdict)


SEEDS = dict(zip(KINDS, range(2400, 2400 + len(KINDS)), strict=True))


@pytest.mark.parametrize("name", list(KINDS))
def test_bars_coloured_by_sign(base, name):
    """Up and down bars of the fit and of the map get two colours, by sign, in each panel;
    the map's bars inside their noise band are fainter than those above it; the legends
    say which way each colour moved."""
    import matplotlib.pyplot as plt

    r = drawn(base, name, SEEDS[name])
    fig = element_figure(r)
    try:
        axes = fig.axes
        for ax, key, words in ((axes[0], "alpha", ("mass added", "mass removed")),
                               (axes[1], "beta", ("stiffer", "softer"))):
            fit_bars, map_bars = ax.containers
            values = np.array([e[key] for e in r.verdict["elements"]])
            up = {tuple(p.get_facecolor()) for p, v in zip(fit_bars, values, strict=True)
                  if v > 0}
            down = {tuple(p.get_facecolor()) for p, v in zip(fit_bars, values, strict=True)
                    if v < 0}
            assert len(up) == 1 and len(down) == 1 and up != down
            m = np.array(r.verdict["details"]["msso"][key])
            band = 2 * np.array(r.verdict["details"]["msso"][key + "_std"])
            edge = np.array([p.get_edgecolor() for p in map_bars])
            assert {tuple(c[:3]) for c in edge[m > 0]} == {tuple(c[:3]) for c in up}
            assert {tuple(c[:3]) for c in edge[m < 0]} == {tuple(c[:3]) for c in down}
            inside = np.abs(m) <= band
            assert inside.any() and (~inside).any()
            assert edge[inside, 3].max() < edge[~inside, 3].min()
            labels = [t.get_text() for t in ax.get_legend().get_texts()]
            assert all(w in labels for w in words)
    finally:
        plt.close(fig)


def _region_words(name: str) -> str:
    return {"handle_substance": "legal grip", "grip_past": "clean the bat"}.get(
        name, KINDS[name][1])


@pytest.mark.parametrize("name", list(KINDS))
def test_finding_region_shaded_and_marked(base, name):
    """The finding's region is shaded on both bar panels, whatever the status, labelled by
    its kind; the bat's drawing shows a core's bore only for a core, else the region's
    stretch of the outline with its words."""
    import matplotlib.pyplot as plt

    r = drawn(base, name, SEEDS[name])
    a, b = r.verdict["finding"]["region_in"]
    words = _region_words(name)
    fig = element_figure(r)
    try:
        for ax in fig.axes[:2]:
            spans = [p for p in ax.patches if words in p.get_label()]
            assert len(spans) == 1
            assert spans[0].get_x() == pytest.approx(a)
            assert spans[0].get_x() + spans[0].get_width() == pytest.approx(b)
        labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        assert any(words in t for t in labels)
        assert not any("core" in t for t in labels)
        profile = fig.axes[2]
        bores = [p for p in profile.patches if "fitted core" in p.get_label()]
        if name == "core":
            d = r.verdict["finding"]["reading"]["core_diameter_in"]
            assert len(bores) == 1 and bores[0].get_height() == pytest.approx(d)
            assert bores[0].get_width() == pytest.approx(b - a)
        else:
            assert not bores
            marked = [c for c in profile.collections if c.get_label().endswith(
                f"{a:.1f}–{b:.1f} in")]
            assert len(marked) == 1
            xs = marked[0].get_paths()[0].vertices[:, 0]
            assert a - 0.5 <= xs.min() and xs.max() <= b + 0.5
    finally:
        plt.close(fig)


def _nesting(text: str) -> int:
    depth = deepest = 0
    for ch in text:
        depth += {"(": 1, ")": -1}.get(ch, 0)
        deepest = max(deepest, depth)
    return deepest


@pytest.mark.parametrize("name", [k for k in KINDS if k != "local_change"])
def test_headline_says_rule_and_reading(base, name):
    """The headline says the rule's word and the drawn reading: grams of metal or of a
    substance, diameter lost along how long, a bore's diameter, length and fill, a grip's
    grams and whether it is legal; no parentheses inside parentheses."""
    r = drawn(base, name, SEEDS[name] + 100)
    f = r.verdict["finding"]
    a, b = f["region_in"]
    g = f["reading"].get("added_mass_g")
    text = headline(r)
    expected = {
        "core": ["filled", f"{f['reading'].get('core_diameter_in', 0):.2f} in across",
                 f"{b - a:.1f} in long",
                 f"{f['reading'].get('fill_density_ratio', 0):.2f} times as dense",
                 f"{a:.1f}-{b:.1f}"],
        "inserted_mass": ["nailed", f"about {g or 0:.0f} g of metal", f"{a:.1f}-{b:.1f}"],
        "surface_coating": ["covered with a substance", f"about {g or 0:.0f} g",
                            f"{a:.1f}-{b:.1f}"],
        "material_removed": ["flat-surfaced",
                             f"{f['reading'].get('diameter_lost_in', 0):.3f} in of the "
                             f"diameter", f"along {b - a:.1f} in", f"{a:.1f}-{b:.1f}"],
        "handle_substance": [f"about {g or 0:.0f} g", f"{a:.0f}-{b:.0f} in",
                             "legal under Rule 3.02(c)"],
        "grip_past": [f"about {g or 0:.0f} g", f"{a:.0f}-{b:.0f} in", "must be cleaned"],
    }[name]
    for part in expected:
        assert part in text, (part, text)
    assert ("has been altered" in text) == (KINDS[name][0] == "altered")
    assert _nesting(text) <= 1, text


def test_record_before_the_rulebook_keeps_its_core(base):
    """An altered record stored without a ``finding`` (before the rulebook) still shades its
    region and draws its fitted core, whose diameter is the record's."""
    import matplotlib.pyplot as plt

    v = base.verdict
    assert v.get("finding") is None and v["status"] == "altered"
    a, b = v["region_in"]
    fig = element_figure(base)
    try:
        spans = [p for p in fig.axes[0].patches if p.get_label() == "finding region: altered"]
        assert len(spans) == 1 and spans[0].get_x() == pytest.approx(a)
        bores = [p for p in fig.axes[2].patches if "fitted core" in p.get_label()]
        assert len(bores) == 1
        assert bores[0].get_height() == pytest.approx(v["core_diameter_in"])
        assert bores[0].get_width() == pytest.approx(b - a)
    finally:
        plt.close(fig)


@pytest.mark.parametrize("name", ["core", "inserted_mass", "material_removed"])
def test_regions_note_names_the_finding(base, name):
    """The sentence under the figure names the fit of what was found: a bore only for a
    core."""
    from batlab.report import regions_note

    r = drawn(base, name, SEEDS[name])
    a, b = r.verdict["finding"]["region_in"]
    msso = {**r.verdict["details"]["msso"], "region_m": [(a - 2) * 0.0254, b * 0.0254]}
    r = replace(r, verdict={**r.verdict, "details": {**r.verdict["details"], "msso": msso}})
    note = regions_note(r)
    rule = KINDS[name][1]
    assert f"{a:.1f}–{b:.1f} in" in note
    assert ("one bore" in note) == (name == "core")
    assert (f"fit ({rule})" in note) == (name != "core")


@pytest.mark.parametrize("name", list(KINDS))
def test_evidence_table_gives_the_finding_and_its_uncertainty(base, name):
    """The evidence table names the finding in the rule's words, its region, and each number
    of its reading with its drawn standard uncertainty."""
    from batlab.report import _facts

    r = drawn(base, name, SEEDS[name] + 200)
    f = r.verdict["finding"]
    rng = np.random.default_rng(SEEDS[name] + 300)
    f["uncertainty"] = {k: float(rng.uniform(0.01, 0.2)) * abs(v)
                        for k, v in f["reading"].items()}
    rows = {str(k): str(v) for k, v in _facts(r)}
    assert f["rule"] in rows["Finding (the rule's words)"]
    a, b = f["region_in"]
    assert rows["Finding region (in from the knob end)"] == f"{a:.2f} – {b:.2f}"
    cells = [v for k, v in rows.items() if k.startswith("Finding: ")]
    assert len(cells) == len(f["reading"])
    for (key, val), cell in zip(f["reading"].items(), cells, strict=True):
        assert cell.startswith("<span class='n'>")  # one number, never broken
        cell = re.sub(r"<[^>]+>", "", cell)
        shown, sd = (float(x) for x in cell.split(" ± "))
        u = f["uncertainty"][key]  # GUM: u to two significant digits, the value to match
        assert len(cell.split(" ± ")[1].replace(".", "").lstrip("0")) == 2, cell
        assert shown == pytest.approx(val, abs=0.05 * u), key
        assert sd == pytest.approx(u, abs=0.05 * u), key
