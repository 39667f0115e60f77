"""The report as a person sees it (issue 50), in Debian's Chromium driven by Playwright.

One browser for the module, four pages drawn from the sample bat's inspection (stand-in
numerics, as in tests/test_report.py) with the verdicts a lab meets: the demo's corked bat
(no calibration on file), a clean bat, an inconclusive one and a legal grip. Checked: the
verdict box's word count; nothing wider than a 390 px phone; every number of a table on one
line; the certificate block's fields; a PDF whose page count is right. The figure's axes are
checked in tests/test_report.py (they are one PNG). Skipped, with the reason, where
/usr/bin/chromium or Playwright is missing (.ci/run installs Chromium).
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import pytest

from batlab import pipeline
from batlab.report import figures_png, render_html
from batlab.verdict_box import MAX_WORDS
from tests.inspect_standins import use_standins

CHROMIUM = Path("/usr/bin/chromium")
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]
SAMPLE = Path("data_samples/smooth_bat")
pytestmark = pytest.mark.skipif(not CHROMIUM.exists(),
                                reason="/usr/bin/chromium not installed (apt-get install "
                                       "chromium; .ci/run installs it)")
LAB = {"name": "Test Bat Lab", "address": "1 Knob Lane, Louisville KY", "operator": "J. Doe",
       "hammer": "PCB 086C03 #1234", "hammer_sensitivity_mv_per_n": 2.25,
       "accelerometer": "PCB 352C23 #5678", "accelerometer_sensitivity_mv_per_ms2": 0.51,
       "band_hz": [20.0, 3000.0], "resolution_hz": 0.5, "averages": 5}
CONDITIONS = {"weight_kg": 0.8095, "sensor_mass_kg": 0.0002, "temperature_c": 21.5,
              "tested_on": "2026-03-14"}
FORBIDDEN = re.compile(r"\bF\b|nominal|unmeasured|[0-9a-f]{10}|--|\$|\.json")
NOMINAL = {"value": 1e-7, "source": "nominal", "calibration": None, "nominal": 1e-7,
           "model": "white-ash-34.0in-7f03ee6881",
           "unmeasured": "no calibration of bat model white-ash-34.0in-7f03ee6881 is stored"}


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """The four pages, written to files: name -> path."""
    with pytest.MonkeyPatch.context() as mp:
        use_standins(mp)
        res = pipeline.inspect_files(SAMPLE / "profile.csv", SAMPLE / "meta.json",
                                     SAMPLE / "baseline.uff", SAMPLE / "retest_corked.uff")
    base = pipeline.report_inputs(res, pipeline.read_meta_dict(SAMPLE / "meta.json"), {})
    base = replace(base, conditions=CONDITIONS)
    v = base.verdict
    core = {"kind": "core", "rule": "filled", "legal": False, "region_in": [24.0, 33.0],
            "reading": {"core_diameter_in": 1.0, "fill_density_ratio": 0.3},
            "uncertainty": {"core_diameter_in": 0.0031, "fill_density_ratio": 0.05}}
    grip = {"kind": "handle_substance", "rule": "grip substance (3.02(c))", "legal": True,
            "region_in": [1.0, 15.0], "reading": {"added_mass_g": 5.2},
            "uncertainty": {"added_mass_g": 1.6}}
    verdicts = {
        "demo": {**v, "finding": core, "chance": NOMINAL},
        "clean": {**v, "status": "not_altered", "altered": False, "finding": None,
                  "region_in": None, "chance": {**NOMINAL, "value": 0.92, "nominal": 0.92},
                  "reasons": ["the change between the tests is what moisture, temperature "
                              "and the accelerometer make"]},
        "inconclusive": {**v, "status": "inconclusive", "altered": None, "region_in": None,
                         "finding": None, "chance": None,
                         "reasons": ["too few modes pair (2 of 6): re-test with more hits"]},
        "grip": {**v, "status": "not_altered", "altered": False, "region_in": None,
                 "finding": grip, "chance": {**NOMINAL, "value": 0.4, "nominal": 0.4}},
    }
    out = tmp_path_factory.mktemp("pages")
    paths = {}
    for name, verdict in verdicts.items():
        r = replace(base, verdict=verdict)
        figures = figures_png(r) if name == "demo" else _blank_figures()
        paths[name] = out / f"{name}.html"
        paths[name].write_text(render_html(r, "2026-03-14T10:00:00", figures, LAB))
    return paths


def _blank_figures() -> dict[str, bytes]:
    """One small PNG for each figure (drawing them is checked on the demo page)."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(10, 4))
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return {"elements": buf.getvalue(), "frf": buf.getvalue(), "mac": buf.getvalue()}


@pytest.fixture(scope="module")
def browser():
    """Debian's Chromium, headless, through Playwright (no downloaded browser)."""
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
        yield b
        b.close()


def _open(browser, path: Path, width: int):
    page = browser.new_page(viewport={"width": width, "height": 844})
    page.goto(path.resolve().as_uri())
    return page


@pytest.mark.parametrize("name", ["demo", "clean", "inconclusive", "grip"])
def test_verdict_box_is_short_and_plain(browser, pages, name):
    page = _open(browser, pages[name], 1280)
    text = page.inner_text(".verdict")
    page.close()
    assert len(text.split()) <= MAX_WORDS, text
    assert not FORBIDDEN.search(text), text


@pytest.mark.parametrize("name", ["demo", "inconclusive"])
def test_phone_layout(browser, pages, name):
    """At 390 px nothing is wider than the screen and no number of a table breaks."""
    page = _open(browser, pages[name], 390)
    wide = page.evaluate("""() => [...document.querySelectorAll('body *')]
        .filter(e => e.getBoundingClientRect().right > window.innerWidth + 1)
        .map(e => e.tagName + '.' + e.className + ': ' + e.textContent.slice(0, 40))""")
    assert page.evaluate("document.documentElement.scrollWidth") <= 390
    split = page.evaluate("""() => [...document.querySelectorAll('td .n')]
        .filter(e => e.getClientRects().length !== 1
                || e.getBoundingClientRect().height > 1.6 * parseFloat(getComputedStyle(e)
                   .lineHeight || getComputedStyle(e).fontSize) + 2)
        .map(e => e.textContent)""")
    numbers = page.evaluate("document.querySelectorAll('td .n').length")
    has_viewport = page.evaluate("!!document.querySelector('meta[name=viewport]')")
    page.close()
    assert wide == []
    assert split == []
    assert numbers > 30  # the check above sees the tables' numbers
    assert has_viewport


def test_certificate_block(browser, pages):
    page = _open(browser, pages["demo"], 1280)
    cert = page.inner_text("table.certificate")
    page.close()
    for field in ("Report number", "BL-HX-2001-0-", "Test Bat Lab", "1 Knob Lane", "J. Doe",
                  "PCB 086C03 #1234", "2.25", "PCB 352C23 #5678", "0.51", "20–3000", "0.5",
                  "Averages per point\t5", "Re-test date\t2026-03-14",
                  "Re-test temperature (°C)\t21.5", "Accelerometer mass at re-test (g)\t0.2",
                  "Weight at re-test (lb, scale)\t1.785", "Decision rule",
                  "coverage factor k = 1"):
        assert field in cert, field


def _pdf_pages(pdf: bytes) -> int:
    """Count a PDF's page objects (``/Type /Page``, not ``/Pages``)."""
    return len(re.findall(rb"/Type\s*/Page(?!s)", pdf))


def test_pdf_page_count(browser, pages, tmp_path):
    """The printed report has as many pages as its page tree says, and one forced page
    break more gives exactly one page more."""
    page = _open(browser, pages["clean"], 1280)
    pdf = page.pdf(format="A4")
    n = _pdf_pages(pdf)
    assert n >= 2
    count = re.search(rb"/Type\s*/Pages.*?/Count\s+(\d+)", pdf, re.S)
    assert count and int(count.group(1)) == n
    more = tmp_path / "more.html"
    more.write_text(pages["clean"].read_text().replace(
        "</body>", "<p style='break-before:page'>one page more</p></body>"))
    page.goto(more.resolve().as_uri())
    assert _pdf_pages(page.pdf(format="A4")) == n + 1
    page.close()
