"""The HTML inspection report: self-contained, atomic, physically right mass changes, and it
renders (headless Chromium screenshot, when Chromium is installed)."""

from __future__ import annotations

import base64
import os
import re
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from batlab import pipeline
from batlab.report import (
    check_destination,
    element_mass_change,
    figures_png,
    headline,
    mass_rows,
    render_html,
    write_report,
)
from tests.inspect_standins import use_standins
from updating.model.mass_properties import mass_properties
from updating.model.units import IN_TO_M, LB_TO_KG

SAMPLE = Path("data_samples/smooth_bat")


def _inputs(res):
    meta = pipeline.read_meta_dict(SAMPLE / "meta.json")
    prov = pipeline.provenance(baseline_sha256=pipeline.file_sha256(SAMPLE / "baseline.uff"),
                               retest_sha256=pipeline.file_sha256(SAMPLE / "retest_corked.uff"))
    return pipeline.report_inputs(res, meta, prov)


@pytest.fixture
def result(monkeypatch):
    use_standins(monkeypatch)
    return _inputs(pipeline.inspect_files(SAMPLE / "profile.csv", SAMPLE / "meta.json",
                                          SAMPLE / "baseline.uff", SAMPLE / "retest_corked.uff"))


def test_report_is_self_contained(result, tmp_path):
    out = tmp_path / "rep"
    path = write_report(out, result)
    assert path == out / "index.html"
    assert sorted(p.name for p in out.iterdir()) == ["index.html"]  # no temporary left over
    page = path.read_text()
    assert "Inspection of bat HX-2001" in page
    assert "Bat HX-2001 has been altered: a bore about 1.00 in across from 24.0 to 33.0 in" in page
    # no calibration of the sample's model (none stored, none shipped): the box says it
    # plainly, the evidence table says once that the chance is unmeasured and gives the
    # nominal 1 - 0.999 beside it
    box = page.split("<div class='verdict altered'>")[1].split("</div>")[0]
    assert "unmeasured" not in box and "nominal" not in box
    assert page.count("unmeasured <span class='note'>(no calibration of bat model") == 1
    assert ("<span class='n'>0.1 %</span> <span class='note'>(p = <span class='n'>0.001</span>)"
            in page)
    assert "confidence" not in page.lower()
    assert pipeline.file_sha256(SAMPLE / "retest_corked.uff") in page  # provenance
    assert "<td>Bat</td><td>HX-2001 (white ash)</td>" in page  # the certificate block
    imgs = re.findall(r'<img src="data:image/png;base64,([A-Za-z0-9+/=]+)"', page)
    assert len(imgs) >= 3  # element bars over the bat, FRF overlay, MAC
    for b64 in imgs:
        assert base64.b64decode(b64)[:8] == b"\x89PNG\r\n\x1a\n"
    assert not re.search(r"(src|href)=\"(?!data:)", page)  # nothing fetched from elsewhere
    assert "<span class='n'>24.00</span> – <span class='n'>33.00</span>" in page  # region, in


def test_report_with_real_fits_has_stabilisation_diagrams(monkeypatch, tmp_path):
    use_standins(monkeypatch, fit=False)
    res = _inputs(pipeline.inspect_files(SAMPLE / "profile.csv", SAMPLE / "meta.json",
                                         SAMPLE / "baseline.uff", SAMPLE / "retest_corked.uff"))
    page = write_report(tmp_path, res, plots_dir=tmp_path / "plots").read_text()
    assert page.count("<h3>Stabilisation diagram: ") == 2
    assert len(re.findall(r'<img src="data:image/png;base64,', page)) == 5
    pngs = sorted(p.name for p in (tmp_path / "plots").iterdir())
    assert pngs == ["elements.png", "frf.png", "mac.png", "stabilisation_baseline.png",
                    "stabilisation_retest.png"]
    for name in pngs:  # the same figures as in the page
        b64 = base64.b64encode((tmp_path / "plots" / name).read_bytes()).decode()
        assert b64 in page


def test_report_destination_is_a_file(result, tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(ValueError, match="not a directory"):
        write_report(tmp_path / "f", result)


def test_unwritable_destination_fails_before_work(result, tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match="file/rep: report destination not writable"):
        check_destination(tmp_path / "file" / "rep")  # (as root too)
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        if os.access(locked, os.W_OK):
            pytest.skip("running as root: a read-only directory is writable")
        with pytest.raises(ValueError, match="locked: report destination not writable"):
            check_destination(locked / "rep")
    finally:
        locked.chmod(0o755)


def test_element_mass_change_uniform_factor(result):
    """alpha = c everywhere scales the whole mass distribution: dm = c m, same centre of mass,
    dI_knob = c I_knob (against the FE model's own section quadrature)."""
    c = -0.05
    els = [{**e, "alpha": c} for e in result.verdict["elements"]]
    d = element_mass_change(replace(result, verdict={**result.verdict, "elements": els}))
    ref = mass_properties(result.reference.build(result.profile))
    assert d.mass_kg == pytest.approx(c * ref.mass_kg, rel=1e-4)
    assert d.cg_m == pytest.approx(ref.cg_m, rel=1e-4)
    assert d.i_knob_kg_m2 == pytest.approx(c * ref.i_knob_kg_m2, rel=1e-4)


def test_fitted_core_mass_change_matches_hand_calculation(result):
    """A 1 in core from 24 to 33 in with fill 0.3: dm = rho (0.3 - 1) pi/4 d^2 l."""
    rows = {r[0]: r for r in mass_rows(result)}
    rho = result.reference.rho_kg_m3
    d, length = 1.0 * IN_TO_M, 9.0 * IN_TO_M
    dm_lb = rho * (0.3 - 1) * np.pi / 4 * d**2 * length / LB_TO_KG
    ref, cored = rows["reference (baseline)"], rows["with the fitted core"]
    assert cored[1] - ref[1] == pytest.approx(dm_lb, rel=0.01)
    # lighter near the barrel: the centre of mass moves toward the knob
    x_core = 28.5
    expect_cg = (ref[1] * ref[2] + dm_lb * x_core) / (ref[1] + dm_lb)
    assert cored[2] == pytest.approx(expect_cg, abs=0.01)


NO_CHROMIUM = pytest.mark.skipif(
    shutil.which("chromium") is None,
    reason="chromium not installed (apt-get install chromium; .ci/run installs it)")


def chromium(args: list[str], tmp_path: Path, text: bool = False) -> str | bytes:
    """Run headless Chromium on ``args`` and return its stdout.

    The flags a CI machine needs: no sandbox (it cannot start as root), no GPU, nothing fetched
    or synchronised in the background, no first-run page, and a fresh profile folder.
    """
    profile = tmp_path / "chromium-profile"
    return subprocess.run(
        ["chromium", "--headless", "--no-sandbox", "--disable-gpu",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--no-first-run", f"--user-data-dir={profile}", *args],
        check=True, capture_output=True, text=text, timeout=90).stdout


@NO_CHROMIUM
def test_report_renders_in_headless_chromium(result, tmp_path):
    from matplotlib.image import imread

    path = write_report(tmp_path / "rep", result)
    shot = tmp_path / "shot.png"
    chromium(["--hide-scrollbars", f"--screenshot={shot}", "--window-size=1100,1800",
              path.resolve().as_uri()], tmp_path)
    img = imread(shot)
    assert img.shape[0] >= 1000 and img.shape[1] >= 1000
    gray = img[..., :3].mean(axis=2)
    assert gray.std() > 0.05  # not a blank page
    assert (gray < 0.5).mean() > 0.002  # some dark text/lines drawn
    reds = (img[..., 0] > 0.6) & (img[..., 1] < 0.5) & (img[..., 2] < 0.5)
    assert reds.sum() > 50  # the red verdict border is on screen


def _with_verdict(inputs, drop=(), **changes):
    merged = {**inputs.verdict, **changes}
    return replace(inputs, verdict={k: v for k, v in merged.items() if k not in drop})


def test_plain_sentence_for_clean_and_inconclusive(result):
    """A clean bat at confidence 0.075 reads as a 92 % chance, never as "7.5 % sure"; an
    inconclusive verdict gives its reasons and no p-value; status derives from ``altered``
    when the verdict has none."""
    clean = _with_verdict(result, drop=("status", "reasons", "chance"), altered=False,
                          confidence=0.075, region_in=None, core_diameter_in=None,
                          fill_density_ratio=None)  # as stored before chances were measured
    text = headline(clean)
    assert text.startswith("Bat HX-2001 shows no sign of alteration")
    assert "chance" not in text  # said once, in the evidence table
    page = render_html(clean, "2026-01-01T00:00:00", figures_png(clean))
    assert ("<span class='n'>92 %</span> <span class='note'>(p = <span class='n'>0.93</span>)"
            in page)
    assert "0.075" not in page and "7.5 %" not in page
    odd = _with_verdict(result, status="inconclusive", altered=None,
                        reasons=["too few modes pair (2 of 6): re-test with more hits"])
    assert headline(odd) == ("No verdict is possible for bat HX-2001: too few modes pair (2 of "
                             "6): re-test with more hits. The bat is not called altered.")
    page = render_html(odd, "2026-01-01T00:00:00", figures_png(odd))
    assert "p-value" not in page and "<div class='verdict inconclusive'>" in page


OVERFLOW_PROBE = """<script>
const bad = [];
const body = document.body.getBoundingClientRect();
document.querySelectorAll('table, img').forEach((el, i) => {
  const r = el.getBoundingClientRect();
  if (r.right > body.right + 1 || el.scrollWidth > el.clientWidth + 1) bad.push(i);
  el.querySelectorAll('td, th').forEach(c => {
    if (c.scrollWidth > c.clientWidth + 1) bad.push(i + ':' + c.textContent.slice(0, 30));
  });
});
document.body.setAttribute('data-overflow', bad.join('|'));
</script>"""


def overflowing(page: str, tmp_path: Path, width: int = 1100) -> str:
    """What overflows the page body when headless Chromium lays it out at ``width`` px (the
    report itself has no script: the probe is added to a copy)."""
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("</body>", OVERFLOW_PROBE + "</body>"))
    dom = chromium([f"--window-size={width},1200", "--dump-dom", probe.resolve().as_uri()],
                   tmp_path, text=True)
    found = re.search(r'data-overflow="([^"]*)"', dom)
    assert found, "the probe did not run"
    return found.group(1)


@NO_CHROMIUM
def test_no_table_overflows_in_chromium(monkeypatch, tmp_path):
    """Every table and figure fits the page, the paired-modes table with all its columns too
    (its headers wrap); and the check fails on a table that does not fit."""
    use_standins(monkeypatch)
    res = pipeline.inspect_files(SAMPLE / "profile.csv", SAMPLE / "meta.json",
                                 SAMPLE / "baseline.uff", SAMPLE / "retest_corked.uff")
    inputs = _inputs(res)
    keys = ["baseline_hz", "retest_hz", "mac", "reference_hz", "mac_reference", "change_pct",
            "moisture_fit_change_pct", "core_fit_change_pct"]
    modes = [{k: 1234.5678 * (i + 1) for k in keys} for i in range(6)]
    inputs = _with_verdict(inputs, modes=modes)
    page = render_html(inputs, "2026-01-01T00:00:00", figures_png(inputs))
    assert "Explained by moisture + core (%)" in page and "core_fit_change_pct" not in page
    for width in (1100, 800):
        assert overflowing(page, tmp_path, width) == "", width
    # a table laid out as the old report did (automatic widths, cells that never wrap)
    wide = page.replace("</body>", "<table style='table-layout:auto;width:auto'><tr>"
                        + "<td style='white-space:nowrap'>moisture_fit_change_pct</td>" * 12
                        + "</tr></table></body>")
    assert overflowing(wide, tmp_path) != ""


def test_report_import_loads_no_stage():
    """The report draws a page: importing it loads neither pyserial, scipy.signal nor the
    modal fit (``batlab.pipeline.records`` is light; the package loads names lazily)."""
    heavy = ("serial", "scipy.signal", "ema.modal_fit", "rigs.driver")
    code = ("import sys, batlab.report; "
            f"print(' '.join(m for m in {heavy!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=Path(__file__).resolve().parents[1])
    assert out.stdout.strip() == ""
    code = ("import sys, batlab.pipeline as p; p.inspect_files; "
            "print('ema.modal_fit' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=Path(__file__).resolve().parents[1])
    assert out.stdout.strip() == "True"  # the check above can fail: a pipeline name loads it


def test_bat_drawing_shares_the_panels_x_axis(result):
    """The to-scale drawing of the bat and the bar panels above it put every inch at the same
    pixel (within 2 px at the page's resolution), with a finding's label above the bat; and
    the drawing stays to scale (an inch up is an inch across, within 2 %)."""
    from batlab.report import element_figure

    finding = {"kind": "inserted_mass", "rule": "nailed", "legal": False,
               "region_in": [30.8, 33.8], "reading": {"added_mass_g": 18.0}}
    r = _with_verdict(result, finding=finding)
    fig = element_figure(r)
    fig.set_dpi(110)  # as the page's PNG
    fig.canvas.draw()
    axes = fig.axes[:3]
    xs = [ax.transData.transform([(0.0, 0.0), (34.0, 0.0)])[:, 0] for ax in axes]
    for x in xs[:2]:
        assert np.abs(x - xs[2]).max() <= 2.0, (x, xs[2])
    ax = axes[2]
    (x0, y0), (x1, y1) = ax.transData.transform([(0.0, 0.0), (1.0, 1.0)])
    assert (y1 - y0) == pytest.approx(x1 - x0, rel=0.02)
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_inconclusive_map_note_does_not_acquit(result):
    """An inconclusive verdict's map note names both regions and never says the decision
    found the change no larger than an unaltered bat's (issue 50: a nailed bat's page said
    both "large against the test's noise" and that)."""
    from batlab.report import regions_note

    n = len(result.verdict["elements"])
    msso = {"alpha": [0.0] * n, "beta": [0.0] * n, "alpha_std": [0.01] * n,
            "beta_std": [0.01] * n, "region_m": [32.1 * IN_TO_M, 33.1 * IN_TO_M]}
    details = {"p_value": 0.2, "statistic": "F", "n_modes": 6, "msso": msso}
    finding = {"kind": "inserted_mass", "rule": "nailed", "legal": False,
               "region_in": [30.9, 32.4], "reading": {"added_mass_g": 9.5}}
    r = _with_verdict(result, status="inconclusive", altered=None, region_in=None,
                      finding=finding, reasons=["the change fits nailed and is large"],
                      details=details)
    note = regions_note(r)
    assert "no larger than an unaltered bat's" not in note
    assert note.startswith("The element map marks 32.1–33.1 in and the possible nailed fit "
                           "30.9–32.4 in")
    assert "no decision" in note


@pytest.mark.parametrize("value, u, text", [
    (1.003, 0.003, "1.0030 ± 0.0030"), (9.54, 1.6, "9.5 ± 1.6"), (45.44, 1.23, "45.4 ± 1.2"),
    (18.2, 0.0996, "18.20 ± 0.10"), (1809198.0, 23456.0, "1,809,000 ± 23,000"),
    (0.074, None, "0.074")])
def test_gum_rounding(value, u, text):
    """An uncertainty to two significant digits, the value to the same place (GUM 7.2.6);
    issue 50's "core diameter 1.003 ± 0.003" and "E 1,809,198 psi"."""
    from batlab.formatting import gum, significant

    assert gum(value, u) == text
    assert significant(1809198.0) == "1,810,000"


def test_report_states_each_weight_once_with_its_source(result):
    """The scale's change and the finding's side by side, in g and %, and whether they agree;
    the re-test's weight in lb in the certificate (issue 50: three weights that disagreed,
    the re-test's never shown)."""
    from batlab.report import certificate_rows, weight_rows, weights_agree

    w0_kg = float(result.meta["weight_lb"]) * LB_TO_KG
    finding = {"kind": "inserted_mass", "rule": "nailed", "legal": False,
               "region_in": [30.9, 32.4], "reading": {"added_mass_g": 9.5},
               "uncertainty": {"added_mass_g": 1.6}}
    r = replace(_with_verdict(result, finding=finding),
                conditions={"weight_kg": w0_kg + 0.002, "tested_on": "2026-03-14"})
    rows = [[str(c) for c in row] for row in weight_rows(r)]
    assert [row[0] for row in rows] == ["Scale", "Vibration"]
    assert rows[1][1] == "<span class='n'>9.5 ± 1.6</span>"
    assert rows[0][1].startswith("<span class='n'>2.0 ± 2.4")  # 0.3 % of 809 g
    assert weights_agree(r).startswith("The scale and the vibration disagree: they differ by "
                                       "7 g, more than twice")
    near = replace(r, conditions={"weight_kg": w0_kg + 0.009})
    assert weights_agree(near).startswith("The scale and the vibration agree: they differ by "
                                          "0 g")
    cert = {str(k): str(v) for k, v in certificate_rows(r, None, "2026-03-14T10:00:00")}
    assert cert["Weight at re-test (lb, scale)"] == \
        f"<span class='n'>{(w0_kg + 0.002) / LB_TO_KG:.3f}</span>"
    assert cert["Re-test date"] == "2026-03-14"
