"""The inspection report: one self-contained HTML page for a lab manager.

The inspection report: one self-contained HTML page (figures embedded as base64 PNG) for a
lab manager.

Drawn from ``ReportInputs`` (the verdict as the registry stores it, the model, both fitted
tests, meta.json, provenance), so a stored inspection's page can be rebuilt from the registry.
Contents: one plain sentence (what, where, how much, how sure); the evidence in readable rows;
element mass (alpha) and stiffness (beta) factors of the finding's fit and of the MSSO map on
one shared symmetric scale with the map's noise band, coloured by sign, over a to-scale drawing
of the bat with the finding marked, and a sentence reconciling the two localisations; mass
properties; paired modes; driving-point FRFs, MAC and stabilisation diagrams; provenance (date,
version, species, weight, file hashes, custody records). Layout: docs/report.md.
"""

from __future__ import annotations

import base64
import html
import io
import os
import re
import tempfile
from pathlib import Path

import numpy as np

from batlab.formatting import (
    decision_level,
    false_alarm_words,
    finding_words,
    gum,
    p_value,
    share,
    significant,
    stated_chance,
    status_of,
)
from batlab.lab import lab_rows
from batlab.pipeline.records import FORCED_KEY, ReportInputs, jsonable, lab_units
from batlab.registry import now_utc
from batlab.report_check import seal_page
from batlab.safe_text import for_page
from batlab.verdict_box import verdict_box
from batlab.version import code_version
from ema.io.atomic_write import atomic_write
from updating.inspect.details import InspectionDetails, ModePair
from updating.inspect.kind_table import HOLLOW_MAX_FILL, OTHER_COLOUR, UNEXPLAINED, kind, kind_of
from updating.inspect.words import percent
from updating.model.mass_properties import MassProperties, mass_properties
from updating.model.sections import Core
from updating.model.units import (
    IN_TO_M,
    KG_M2_TO_LB_IN2,
    LB_TO_KG,
    LBF_IN3_TO_KG_M3,
    PSI_TO_PA,
)


def stored_details(v: dict) -> InspectionDetails:
    """Read the stored verdict record's evidence.

    The stored verdict record's evidence, typed; the MSSO map's element ends are the
    record's ``elements``.
    """
    els = v.get("elements") or []
    return InspectionDetails.from_json_dict(v.get("details"),
                                            [e["x0_in"] * IN_TO_M for e in els],
                                            [e["x1_in"] * IN_TO_M for e in els])


def _data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _png_bytes(fig) -> bytes:
    """Encode a figure as PNG bytes (the figure is closed)."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def stabilisation_png(fit) -> bytes:
    """Draw the fit's stabilisation diagram (``ema.plots.plot_stabilisation``) as PNG bytes."""
    from ema.plots import plot_stabilisation

    with tempfile.TemporaryDirectory(prefix="batlab-report-") as tmp:
        return plot_stabilisation(fit, Path(tmp) / "stab.png").read_bytes()


def _db(h: np.ndarray) -> np.ndarray:
    return 20 * np.log10(np.maximum(np.abs(h), 1e-300))


def frf_figure(result: ReportInputs):
    """Driving-point accelerance, dB re 1 (m/s^2)/N: baseline, re-test, re-test synthesis."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 3.6))
    for ft, label, style in ((result.baseline, "baseline", dict(color="0.55", lw=1.0)),
                             (result.retest, "re-test", dict(color="C0", lw=1.0))):
        i, j = ft.test.driving_point
        ax.plot(ft.test.freq_hz, _db(ft.test.frf[:, i, j]), label=f"{label} ({ft.name})",
                **style)
    fit = result.retest.fit
    if fit is not None:
        i, j = result.retest.test.driving_point
        ax.plot(fit.band_freq_hz, _db(fit.synth[:, i, j]), "--", color="C3", lw=1.0,
                label="re-test, synthesised from the fitted modes")
    for f in result.baseline.modes.freq_hz:
        ax.axvline(f, color="0.8", lw=0.6, zorder=0)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("|H| (dB re 1 (m/s²)/N)")
    ax.set_title("Driving-point FRF")
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    return fig


def mac_figure(result: ReportInputs):
    """MAC between the baseline's and the re-test's mode shapes (same points)."""
    import matplotlib.pyplot as plt

    from ema.shapes.mac import mac

    a, b = result.baseline.modes, result.retest.modes
    m = mac(a.shapes, b.shapes)
    fig, ax = plt.subplots(figsize=(0.6 * m.shape[1] + 2.5, 0.6 * m.shape[0] + 1.8))
    im = ax.imshow(m, vmin=0, vmax=1, cmap="Blues")
    for (r, c), v in np.ndenumerate(m):
        ax.text(c, r, f"{v:.2f}", ha="center", va="center", fontsize=7,
                color="white" if v > 0.6 else "black")
    ax.set_xticks(range(m.shape[1]), [f"{f:.0f}" for f in b.freq_hz], rotation=45)
    ax.set_yticks(range(m.shape[0]), [f"{f:.0f}" for f in a.freq_hz])
    ax.set_xlabel("re-test mode (Hz)")
    ax.set_ylabel("baseline mode (Hz)")
    ax.set_title("MAC baseline vs re-test")
    fig.colorbar(im, ax=ax, shrink=0.8)
    return fig


def _symmetric_limit(values, floor: float) -> float:
    """Return a symmetric axis limit.

    A symmetric axis limit: the largest magnitude plus 15 %, never below ``floor`` (so that
    noise does not fill the axis of a clean bat).
    """
    vals = np.abs(np.concatenate([np.ravel(np.asarray(v, dtype=float)) for v in values]))
    vals = vals[np.isfinite(vals)]
    return max(1.15 * float(vals.max()) if vals.size else 0.0, floor)


SCALE_FLOOR = 0.05
"""Element-plot axes show at least +-5 % change: a clean bat's bars stay visibly small."""


SIGN_COLOURS = ("#2166ac", "#e08214")
"""Bar colours by sign (blue, orange; told apart with colour blindness): an element that
gained (mass added, stiffer), one that lost (mass removed, softer)."""
SIGN_WORDS = {"alpha": ("mass added", "mass removed"), "beta": ("stiffer", "softer")}
"""The legend's words for a bar pointing up, down, per panel."""
FADED = 0.3
"""Opacity of a map bar inside its noise band (not a change)."""


def shown_finding(v: dict) -> dict | None:
    """Return the finding the element figure marks, or None.

    The verdict's ``finding`` (an alteration, a grip substance, or what an inconclusive
    verdict could not tell apart); for an altered record stored before the rulebook (no
    ``finding``), its core, or a change of no named kind, over its ``region_in``.
    """
    f = v.get("finding")
    if f and f.get("region_in"):
        return f
    if status_of(v) != "altered" or not v.get("region_in"):
        return None
    core = v.get("core_diameter_in")
    return {"kind": "core" if core else "local_change", "legal": False,
            "region_in": v["region_in"], "rule": "altered",
            "reading": {"core_diameter_in": core} if core else {}}


def finding_label(f: dict, status: str) -> tuple[str, str, str]:
    """Say what a finding is in a few words, for a legend and the drawing of the bat.

    Parameters
    ----------
    f : dict
        The finding (``shown_finding``).
    status : str
        The verdict's status.

    Returns
    -------
    tuple of str
        (region's legend label, short words, colour): "finding region: nailed", "nailed";
        "legal grip (Rule 3.02(c))", "legal grip"; a grip past 18 in says to clean the bat,
        a finding with no verdict says so: its kind's ``label``, ``short`` and ``colour``
        (``updating.inspect.kind_table``).
    """
    k = kind_of(f["kind"], f.get("rule")) or kind(UNEXPLAINED)
    rule = str(f.get("rule") or f["kind"].replace("_", " "))
    label, short = k.label.format(rule=rule), k.short.format(rule=rule)
    if not k.alteration or status == "altered":
        return label, short, k.colour
    return f"{label} (no verdict)", f"{short}?", OTHER_COLOUR


def sign_colours(values: np.ndarray, opacity: np.ndarray | float = 1.0) -> np.ndarray:
    """Return one RGBA colour per bar: ``SIGN_COLOURS`` by the sign of ``values`` (0 is up)."""
    from matplotlib.colors import to_rgba_array

    rgba = to_rgba_array(SIGN_COLOURS)[(np.asarray(values) < 0).astype(int)]
    rgba[:, 3] = opacity
    return rgba


def _map_factors(emap, n: int) -> dict:
    """Return per factor ("alpha", "beta") the map's values and 2 sigma band, or None.

    None for both without a map of ``n`` elements; a map without standard deviations has
    a zero band.
    """
    if emap is None or emap.alpha.size != n:
        return {"alpha": None, "beta": None}
    return {k: (m, 2 * (std if std.size else np.zeros(n)))
            for k, m, std in (("alpha", emap.alpha, emap.alpha_std),
                              ("beta", emap.beta, emap.beta_std))}


def _bar_panel(ax, x0: np.ndarray, w: np.ndarray, fit: np.ndarray, shown, region) -> list:
    """Draw one panel's bars, coloured by sign, and return its legend handles.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The panel.
    x0, w : numpy.ndarray
        (e,) element starts and lengths, in.
    fit : numpy.ndarray
        (e,) the fitted change's factors (solid, left half of each element).
    shown : tuple of numpy.ndarray or None
        The map's factors and their 2 sigma band (hatched, right half; faded inside the
        band), or None.
    region : tuple or None
        (start_in, end_in, label, colour) of the finding, shaded; or None.

    Returns
    -------
    list
        The noise band's and the region's artists, for a legend.
    """
    handles = []
    if shown is not None:
        msso, band = shown
        edges = np.append(x0, x0[-1] + w[-1])
        b = np.append(band, band[-1])
        handles.append(ax.fill_between(edges, -b, b, step="post", color="0.6", alpha=0.3, lw=0,
                                       label="map noise band (±2σ); map bars inside it faded"))
    ax.bar(x0, fit, width=w / 2 if shown is not None else w, align="edge",
           color=sign_colours(fit), edgecolor="k", lw=0.4)
    if shown is not None:
        opacity = np.where(np.abs(msso) <= band, FADED, 1.0)
        ax.bar(x0 + w / 2, msso, width=w / 2, align="edge", color=sign_colours(msso,
               0.15 * opacity), edgecolor=sign_colours(msso, opacity), hatch="////", lw=0.6)
    if region is not None:
        a, b2, label, colour = region
        handles.append(ax.axvspan(a, b2, color=colour, alpha=0.12, lw=0, label=label))
    ax.axhline(0, color="k", lw=0.6)
    return handles


def _bar_legends(axes, handles: list, has_map: bool) -> None:
    """Write each panel's legend: its signs' words (and, on the top panel, the rest)."""
    from matplotlib.patches import Patch

    kinds = [Patch(facecolor="0.85", edgecolor="k", lw=0.4, label="solid: fitted change "
                   "(how much)")]
    if has_map:
        kinds.append(Patch(facecolor="none", edgecolor="0.3", hatch="////", lw=0.6,
                           label="hatched: element map (where)"))
    for ax, key, extra in ((axes[0], "alpha", kinds + handles), (axes[1], "beta", [])):
        signs = [Patch(facecolor=c, edgecolor="k", lw=0.4, label=word)
                 for c, word in zip(SIGN_COLOURS, SIGN_WORDS[key], strict=True)]
        ax.legend(handles=signs + extra, fontsize=8, loc="lower left", ncol=3,
                  bbox_to_anchor=(0.0, 1.0), borderaxespad=0.2, frameon=False)


def _profile_panel(ax, r: ReportInputs, f: dict | None, words: str, colour: str) -> None:
    """Draw the bat to scale (inches) with the test points and what the verdict found.

    A core as its bore (diameter by length); any other finding as its stretch of the
    outline shaded, under a bracket with the finding's words.
    """
    import matplotlib.pyplot as plt

    prof = r.profile
    x = prof.x_m / IN_TO_M
    rad = prof.diameter_m / IN_TO_M / 2
    d_max = 2 * float(rad.max())
    top = 0.75 * d_max
    ax.fill_between(x, -rad, rad, color="burlywood", edgecolor="saddlebrown", lw=0.8)
    if f is not None:
        a, b = f["region_in"]
        core_in = (f.get("reading") or {}).get("core_diameter_in") or \
            r.verdict.get("core_diameter_in")
        if f["kind"] == "core" and core_in:
            ax.add_patch(plt.Rectangle((a, -core_in / 2), b - a, core_in, color=colour,
                                       alpha=0.7, label=f"fitted core ({words})"))
        else:
            xs = np.concatenate([[a], x[(x > a) & (x < b)], [b]])
            rs = np.interp(xs, x, rad)
            ax.fill_between(xs, -rs, rs, color=colour, alpha=0.55, lw=0,
                            label=f"{words}, {a:.1f}–{b:.1f} in")
            y = 0.6 * d_max
            ax.plot([a, a, b, b], [y - 0.1 * d_max, y, y, y - 0.1 * d_max], color=colour, lw=1.5)
            ax.text((a + b) / 2, y + 0.04 * d_max, words, ha="center", va="bottom", fontsize=8,
                    color="k")
            top = 1.05 * d_max
    pts = r.baseline.modes.x_m / IN_TO_M
    ax.plot(pts, np.zeros_like(pts), "k+", ms=5, label="test points")
    ax.legend(fontsize=8, loc="lower left", ncol=2)
    ax.set_ylim(-0.75 * d_max, top)
    ax.set_xlim(-0.5, prof.length_m / IN_TO_M + 0.5)
    ax.set_xlabel("x from the knob end (in)")
    ax.set_ylabel("in")


def element_figure(r: ReportInputs):
    """Draw the element factors over the bat.

    Alpha and beta per element as bars, over the bat's profile drawn to scale (inches):
    the fitted change's factors (how much; left half of each element) beside the MSSO map
    (where; right half, hatched) with its +-2 sigma noise band, a map bar inside it faded.
    Each bar is coloured by its sign (``SIGN_COLOURS``: mass added or removed, stiffer or
    softer). The finding's region (an alteration, a legal grip, what an inconclusive verdict
    could not tell apart) is shaded with its kind in the legend. One symmetric scale, shared
    by both panels and both kinds of bar, at least +-SCALE_FLOOR: the bars compare by eye and
    noise never fills a clean bat's plot.
    """
    import matplotlib.pyplot as plt

    v = r.verdict
    els = v.get("elements") or []
    x0 = np.array([e["x0_in"] for e in els], dtype=float)
    w = np.array([e["x1_in"] for e in els], dtype=float) - x0
    fit = {k: np.array([e[k] for e in els], dtype=float) for k in ("alpha", "beta")}
    emap = stored_details(v).msso.result
    shown = _map_factors(emap, len(x0))
    has_map = shown["alpha"] is not None
    lim = _symmetric_limit([*fit.values(), *(a for m in shown.values() if m for a in m)],
                           SCALE_FLOOR)
    f = shown_finding(v)
    label, words, colour = finding_label(f, status_of(v)) if f else ("", "", "")
    region = (*f["region_in"], label, colour) if f else None
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(10, 7.8),
                             gridspec_kw={"height_ratios": [2.2, 2.2, 1.7]})
    handles = []
    for ax, key, name in ((axes[0], "alpha", "mass change, alpha"),
                          (axes[1], "beta", "stiffness change, beta")):
        own = _bar_panel(ax, x0, w, fit[key], shown[key], region)
        if has_map and emap.region_m:
            a, b = emap.region_m
            own.append(ax.axvspan(a / IN_TO_M, b / IN_TO_M, fill=False, hatch="..",
                                  color="0.4", alpha=0.25, lw=0, label="map region"))
        handles = own if key == "alpha" else handles
        ax.set_ylim(-lim, lim)
        ax.set_ylabel(name)
        ax.grid(alpha=0.3, axis="y")
    _bar_legends(axes, handles, has_map)
    fig.suptitle("Element changes along the bat (knob at 0)", fontsize=11)
    _profile_panel(axes[2], r, f, words, colour)
    fig.tight_layout()
    to_scale(fig, axes[2])
    return fig


def to_scale(fig, ax) -> None:
    """Draw ``ax`` to scale (an inch across is an inch up) without narrowing it.

    ``set_aspect("equal")`` shrinks the axes' width and so moves the drawing of the bat off
    the bar panels it shares its x axis with; here the y limits grow around the drawn ones
    instead, so every panel keeps one width and one x axis.
    """
    fig.canvas.draw()
    box = ax.get_window_extent()
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    span = (x1 - x0) * box.height / box.width
    pad = max(span - (y1 - y0), 0.0) / 2
    ax.set_ylim(y0 - pad, y1 + pad)


# --- mass properties ---------------------------------------------------------------------------


def element_mass_change(r: ReportInputs, n_quad: int = 24) -> MassProperties:
    """Return the mass properties the element factors add.

    Mass, first and second moments added by the element factors, as a MassProperties of the
    change: dm = sum alpha_e int rho A dx, d(m x_cg) = sum alpha_e int rho A x dx,
    dI_knob = sum alpha_e int (rho A x^2 + rho I) dx, I = pi D^4 / 64 (the section's own
    rotary inertia, as in ``updating.model.mass_properties``);
    cg_m holds d(m x_cg) / dm, i_cg is 0.
    """
    els = r.verdict.get("elements") or []
    rho = r.reference.rho_kg_m3
    x0 = np.array([e["x0_in"] for e in els], dtype=float) * IN_TO_M
    x1 = np.array([e["x1_in"] for e in els], dtype=float) * IN_TO_M
    t, w = np.polynomial.legendre.leggauss(n_quad)
    half = (x1 - x0)[:, None] / 2
    xq = (x0 + x1)[:, None] / 2 + half * t[None, :]
    wq = half * w[None, :]
    dq = r.profile.diameter_at(xq)
    rho_a = rho * np.pi / 4 * dq**2
    rho_i = rho * np.pi / 64 * dq**4
    alpha = np.array([e["alpha"] for e in els], dtype=float)[:, None]
    dm = float(np.sum(alpha * wq * rho_a))
    dmx = float(np.sum(alpha * wq * rho_a * xq))
    di = float(np.sum(alpha * wq * (rho_a * xq**2 + rho_i)))
    return MassProperties(dm, dmx / dm if dm else 0.0, di, 0.0)


def mass_rows(r: ReportInputs) -> list[tuple[str, float, float, float]]:
    """Tabulate the mass properties of the reference and of the fits.

    (label, weight lb, centre of mass in, I_knob lb in^2): reference, with the element
    factors applied, with the fitted core.
    """
    ref = mass_properties(r.reference.build(r.profile))
    rows = [("reference (baseline)", ref.mass_kg, ref.cg_m, ref.i_knob_kg_m2)]
    d = element_mass_change(r)
    m = ref.mass_kg + d.mass_kg
    rows.append(("with the element factors", m, (ref.mass_kg * ref.cg_m + d.mass_kg * d.cg_m) / m,
                 ref.i_knob_kg_m2 + d.i_knob_kg_m2))
    v = r.verdict
    region, core_in, fill = v.get("region_in"), v.get("core_diameter_in"), \
        v.get("fill_density_ratio")
    if status_of(v) == "altered" and region and core_in and fill is not None:
        length = r.profile.length_m
        a, b = region[0] * IN_TO_M, region[1] * IN_TO_M
        core = Core(core_in * IN_TO_M, length - a, fill, plug_m=max(length - b, 0.0))
        c = mass_properties(r.reference.build(r.profile, core=core))
        rows.append(("with the fitted core", c.mass_kg, c.cg_m, c.i_knob_kg_m2))
    return [(label, mk / LB_TO_KG, cg / IN_TO_M, i * KG_M2_TO_LB_IN2)
            for label, mk, cg, i in rows]


def _scale_change_g(r: ReportInputs) -> tuple[float, float] | None:
    """Return the scale's weight change since registration and its standard uncertainty, g.

    The re-test's weight (retest.json) less the registered one (meta.json); the uncertainty
    is ``WEIGHT_SIGMA_REL`` of the weight (two scales, tape and dirt), as the inspection
    weighs it. None without both weights.
    """
    from updating.inspect.hypotheses import WEIGHT_SIGMA_REL

    w1 = (r.conditions or {}).get("weight_kg")
    w0 = r.meta.get("weight_lb")
    if w1 is None or w0 is None:
        return None
    w0_kg = float(w0) * LB_TO_KG
    return 1e3 * (float(w1) - w0_kg), 1e3 * WEIGHT_SIGMA_REL * w0_kg


def _finding_change_g(r: ReportInputs) -> tuple[float, float | None, str] | None:
    """Return the finding's weight change, g, its uncertainty and its source's words."""
    f = r.verdict.get("finding") or {}
    read, unc = f.get("reading") or {}, f.get("uncertainty") or {}
    for key, sign in (("added_mass_g", 1.0), ("removed_mass_g", -1.0)):
        if isinstance(read.get(key), (int, float)):
            first = str((r.verdict.get("reasons") or [""])[0])
            how = ("calipers: the re-test's diameters against the registered profile"
                   if f.get("kind") == "material_removed" and "caliper" in first else
                   f"vibration: the finding's fit ({f.get('rule')})")
            u = unc.get(key)
            return sign * float(read[key]), None if u is None else float(u), how
    return None


def weight_rows(r: ReportInputs) -> list[list]:
    """Return the weight change by source, side by side (scale, calipers or vibration).

    Each row: source, change in g with its standard uncertainty (GUM rounding), change in
    %, and how it was obtained. Empty when no source gives one.
    """
    w0_g = 1e3 * mass_rows(r)[0][1] * LB_TO_KG
    rows: list[list] = []
    scale = _scale_change_g(r)
    if scale is not None:
        rows.append(["Scale", _Raw(_num(gum(scale[0], scale[1], 1))),
                     _Raw(nobreak_numbers(f"{100 * scale[0] / w0_g:+.1f}")),
                     "the re-test's weight less the registered weight"])
    found = _finding_change_g(r)
    if found is not None:
        rows.append([found[2].split(":")[0].capitalize(),
                     _Raw(_num(gum(found[0], found[1], 1))),
                     _Raw(nobreak_numbers(f"{100 * found[0] / w0_g:+.1f}")), found[2]])
    return rows


def weights_agree(r: ReportInputs) -> str:
    """Say whether the scale and the finding agree on the weight change ('' unless both).

    They agree when they differ by less than twice the standard uncertainty of their
    difference (k = 2).
    """
    scale, found = _scale_change_g(r), _finding_change_g(r)
    if scale is None or found is None:
        return ""
    u = float(np.hypot(scale[1], found[1] or 0.0))
    diff = found[0] - scale[0]
    name = found[2].split(":")[0]
    if abs(diff) <= 2 * u:
        return (f"The scale and the {name} agree: they differ by {abs(diff):.0f} g, within "
                f"twice the uncertainty of their difference ({2 * u:.0f} g).")
    return (f"The scale and the {name} disagree: they differ by {abs(diff):.0f} g, more than "
            f"twice the uncertainty of their difference ({2 * u:.0f} g); re-weigh the bat "
            "(without the accelerometer) before relying on either.")


# --- words -----------------------------------------------------------------------------------


def headline(r: ReportInputs) -> str:
    """Say the finding in the rule's words, with inches and ounces (below the verdict box).

    How sure is said once, in the box; its numbers once, in the evidence table.
    """
    v, serial = r.verdict, r.serial
    status = status_of(v)
    if status == "inconclusive":
        reasons = v.get("reasons") or ["the two tests cannot be compared"]
        return (f"No verdict is possible for bat {serial}: " + "; ".join(reasons) +
                ". The bat is not called altered.")
    if status == "altered":
        text = f"Bat {serial} has been altered"
        words = finding_words(v.get("finding"), r.profile.length_m / IN_TO_M)
        region, core, fill = v.get("region_in"), v.get("core_diameter_in"), \
            v.get("fill_density_ratio")
        if words:
            text += f" — {words}"
        elif region:
            size = f"a bore about {core:.2f} in across " if core else "a change "
            text += f": {size}from {region[0]:.1f} to {region[1]:.1f} in from the knob end"
            if fill is not None:
                text += (", left hollow" if fill < HOLLOW_MAX_FILL else
                         f", filled with material about {fill:.2f} times as dense as the wood")
        rows = mass_rows(r)
        if len(rows) == 3:
            d_oz = (rows[2][1] - rows[0][1]) * 16
            weight = f"{abs(d_oz):.1f} oz {'lighter' if d_oz < 0 else 'heavier'}"
            text += f"; {weight}" if words else f" ({weight})"
        return text + "."
    text = (f"Bat {serial} shows no sign of alteration: the re-test differs from the baseline "
            "no more than moisture, temperature and re-mounting the sensor explain.")
    grip = finding_words(v.get("finding"))
    if grip:
        text += f" Found: {grip}."
    return text


def decision_rule(v: dict) -> str:
    """Say the decision rule in one sentence (the certificate's)."""
    alpha = decision_level(v)
    level = percent(alpha) if alpha else "1 %"
    return ("A bat is called altered only when its re-test differs from its baseline more "
            "than moisture, temperature and re-mounting the sensor can explain, at a chance "
            f"below {level} for an unaltered bat; otherwise it is not altered, or, when the "
            "two tests cannot be compared, no verdict is given.")


def report_number(r: ReportInputs) -> str:
    """Return the report's number: unique to its inspection and stable when redrawn.

    "BL-SERIAL-N-XXXXXXXX": N the bat's own inspection number (0 for a stateless one), the
    tail the first 8 hex digits of the SHA-256 of the verdict record's hash (stored) or of
    both files' hashes and the verdict's status (stateless).
    """
    import hashlib

    pv = r.provenance
    seed = pv.get("verdict_record_sha256") or "|".join(
        str(x) for x in (pv.get("baseline_sha256"), pv.get("retest_sha256"),
                         status_of(r.verdict), r.verdict.get("statistic")))
    tail = hashlib.sha256(seed.encode()).hexdigest()[:8].upper()
    return f"BL-{r.serial}-{pv.get('bat_inspection', 0)}-{tail}"


def _conditions_rows(r: ReportInputs) -> list[list]:
    """Return the certificate's rows for the re-test's conditions (retest.json)."""
    c = r.conditions or {}
    if not any(v is not None for v in c.values()):
        return [["Re-test conditions", "not given (no retest.json)"]]
    rows: list[list] = []
    if c.get("tested_on"):
        rows.append(["Re-test date", str(c["tested_on"])])
    if c.get("temperature_c") is not None:
        rows.append(["Re-test temperature (°C)", _Raw(_num(f"{c['temperature_c']:.1f}"))])
    if c.get("sensor_mass_kg") is not None:
        rows.append(["Accelerometer mass at re-test (g)",
                     _Raw(_num(f"{1e3 * c['sensor_mass_kg']:.1f}"))])
    if c.get("weight_kg") is not None:
        rows.append(["Weight at re-test (lb, scale)",
                     _Raw(_num(f"{c['weight_kg'] / LB_TO_KG:.3f}"))])
    return rows


def certificate_rows(r: ReportInputs, lab: dict | None, generated_at: str) -> list[list]:
    """Return the certificate block: report number, bat, lab, equipment, conditions, rule."""
    pv, meta = r.provenance, r.meta
    rows: list[list] = [["Report number", _Raw(f"<b>{html.escape(report_number(r))}</b>")],
                        ["Report generated (UTC)", generated_at[:19].replace("T", " ")],
                        ["Bat", f"{r.serial} ({meta.get('species') or 'species not given'})"]]
    if pv.get("bat_inspection") is not None:
        when = pv["inspected_at"][:10]
        rows.append(["Inspection", f"inspection {pv['bat_inspection']} of bat {r.serial}, "
                                   f"{when} (registry inspection #{pv['inspection_id']})"])
    rows += [list(x) for x in lab_rows(lab)]
    if meta.get("weight_lb") is not None:
        rows.append(["Weight at registration (lb, scale)",
                     _Raw(_num(f"{float(meta['weight_lb']):.3f}"))])
    rows += _conditions_rows(r)
    rows.append(["Decision rule", decision_rule(r.verdict)])
    rows.append(["Uncertainties", "each stated as ± one standard uncertainty (coverage factor "
                                  "k = 1, about 68 %); double it for k = 2 (about 95 %)"])
    return rows


def _num(text: str) -> str:
    """Wrap a number so that it never breaks across lines."""
    return f"<span class='n'>{html.escape(text)}</span>"


def _fit_words(v: dict) -> tuple[str, str, str]:
    """Name the altered verdict's fit: (its name, what it is, how its change spreads).

    A core (or a record from before the rulebook): "core fit", "the one bore", "a bore's
    stiffness loss"; any other finding: "fit (nailed)", "the one change of its kind", "a
    local change".
    """
    f = v.get("finding") or {}
    if f.get("kind", "core") == "core":
        return "core fit", "the one bore", "a bore's stiffness loss"
    return f"fit ({f.get('rule')})", "the one change of its kind", "a local change"


def regions_note(r: ReportInputs) -> str:
    """Write the two localisations side by side, reconciled or their difference explained."""
    v = r.verdict
    emap = stored_details(v).msso
    if emap.error is not None:
        return f"The element map could not be computed ({emap.error})."
    if emap.result is None:
        return ""
    return (MAP_JUDGED_AGAIN if v.get("map_judged_again") else "") + _regions_words(r, emap)


MAP_JUDGED_AGAIN = ("The element map was computed when this report was drawn, by judging the "
                    "stored tests again (they gave the stored status and F); it is not part "
                    "of the signed verdict record. ")
"""What a report says of a map its inspection did not store (``pipeline.with_element_map``)."""


def _regions_words(r: ReportInputs, emap) -> str:
    """Write the two localisations' words for a map (``regions_note``)."""
    v = r.verdict
    fit = v.get("region_in") if status_of(v) == "altered" else None
    mreg = emap.region_m
    mreg = None if not mreg else (mreg[0] / IN_TO_M, mreg[1] / IN_TO_M)
    pts = np.sort(r.baseline.modes.x_m) / IN_TO_M
    spacing = float(np.median(np.diff(pts))) if pts.size > 1 else float("nan")
    n_modes = len(v.get("modes") or [])
    if fit is None and mreg is None:
        return ("Neither the fit nor the element map finds an alteration: every "
                "element's map bar stays within its noise band.")
    if fit is None and status_of(v) == "inconclusive":
        f = v.get("finding") or {}
        fit_words = "" if not f.get("region_in") else (
            f" and the possible {f.get('rule')} fit {f['region_in'][0]:.1f}–"
            f"{f['region_in'][1]:.1f} in")
        return (f"The element map marks {mreg[0]:.1f}–{mreg[1]:.1f} in{fit_words}; the verdict "
                "gives no decision (its reason is above), and a map alone never calls a bat "
                "altered.")
    if fit is None:
        return (f"The element map marks {mreg[0]:.1f}–{mreg[1]:.1f} in, but the decision test, "
                "which allows for moisture and re-mounting, found the change no larger than an "
                "unaltered bat's: it is not taken as an alteration.")
    name, what, spread = _fit_words(v)
    if mreg is None:
        return (f"The {name} places the change at {fit[0]:.1f}–{fit[1]:.1f} in; no element of "
                "the map rises above its noise band (the map resolves less than the fit, which "
                f"uses every mode at once): the location rests on the {name}.")
    lo, hi = max(fit[0], mreg[0]), min(fit[1], mreg[1])
    if lo >= hi:
        return (f"The {name} ({fit[0]:.1f}–{fit[1]:.1f} in) and the element map "
                f"({mreg[0]:.1f}–{mreg[1]:.1f} in) disagree on where the change is: treat the "
                "location as uncertain and re-test with more points over both regions.")
    inside = mreg[0] <= fit[0] and fit[1] <= mreg[1]
    return (f"The {name} ({fit[0]:.1f}–{fit[1]:.1f} in) is {what} that best explains "
            f"all the frequency changes; the element map ({mreg[0]:.1f}–{mreg[1]:.1f} in) marks "
            "every element whose change stands above its noise band. "
            + ("The fit lies inside the map's region" if inside else
               f"They overlap from {lo:.1f} to {hi:.1f} in")
            + f": the map is wider because {n_modes} modes measured at points "
            f"{spacing:.1f} in apart cannot pin a change to single elements, and {spread} "
            f"spreads to its neighbours. The {name}'s region is the one to act on.")


# --- page ------------------------------------------------------------------------------------

CSS = """
body{font-family:system-ui,Segoe UI,Helvetica,Arial,sans-serif;max-width:1000px;margin:24px auto;
color:#222;padding:0 12px;line-height:1.4}
h1{margin-bottom:4px}.verdict{font-size:1.2em;padding:8px 16px;border-radius:6px;margin:12px 0}
.verdict p{margin:4px 0}.verdict p:first-child{font-weight:700;font-size:1.15em}
.n{white-space:nowrap}
.altered{background:#fde2e1;border:2px solid #c0392b}
.not_altered{background:#e3f5e1;border:2px solid #27ae60}
.inconclusive{background:#fdf3d8;border:2px solid #d4a017}
table{border-collapse:collapse;margin:8px 0;width:100%;table-layout:fixed;font-size:.9em}
td,th{border:1px solid #ccc;padding:3px 6px;text-align:right;overflow-wrap:break-word;
hyphens:manual}
th{background:#f3f3f3;font-weight:600}td:first-child,th:first-child{text-align:left}
table.facts td:first-child{width:45%}table.facts td{text-align:left}
img{max-width:100%;display:block;margin:8px 0}.note{color:#555;font-size:.9em}
code{font-size:.85em;overflow-wrap:anywhere}
@media (max-width:640px){body{margin:8px auto;padding:0 8px}h1{font-size:1.4em}
table.wide thead{display:none}table.wide,table.wide tbody,table.wide tr{display:block}
table.wide tr{border:1px solid #ccc;margin:6px 0}table.wide td{display:block;border:0;
text-align:right}table.wide td::before{content:attr(data-label);float:left;font-weight:600;
text-align:left;max-width:60%}table.facts td:first-child{width:40%}}
@media print{body{max-width:none;margin:0;padding:0;font-size:10pt}
h2{break-after:avoid}img,table,.verdict{break-inside:avoid}}
"""

MODE_HEADERS = {
    "baseline_hz": "Baseline (Hz)", "retest_hz": "Re-test (Hz)",
    "mac": "Shape match, baseline vs re-test (MAC)", "reference_hz": "Model (Hz)",
    "mac_reference": "Shape match, model (MAC)", "change_pct": "Measured change (%)",
    "moisture_fit_change_pct": "Explained by moisture alone (%)",
    "core_fit_change_pct": "Explained by moisture + core (%)",
}


def _label(key: str) -> str:
    """Make a readable header for a key without one in MODE_HEADERS (units from its suffix)."""
    if key in MODE_HEADERS:
        return MODE_HEADERS[key]
    for suffix, unit in (("_hz", "Hz"), ("_pct", "%"), ("_in", "in"), ("_m", "m")):
        if key.endswith(suffix):
            return key[: -len(suffix)].replace("_", " ").capitalize() + f" ({unit})"
    return key.replace("_", " ").capitalize()


def _fmt(v, spec: str = ".4g") -> str:
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int, float, np.floating, np.integer)):
        return format(float(v), spec)
    return html.escape(str(v))


def _mode_cell(key: str, v) -> str:
    if not isinstance(v, (int, float)) or isinstance(v, bool):
        return _fmt(v)
    if key.endswith("_hz"):
        return f"{v:.1f}"
    if key.endswith("_pct"):
        return f"{v:+.2f}"
    return f"{v:.3f}" if key.startswith("mac") else _fmt(v)


_NUMBER = re.compile(r"(?<![\w.#\-:/])[+\-−±]?(?:\d{1,3}(?:,\d{3})+|\d+)(?:\.\d+)?"
                     r"(?:\s?%)?(?![\w.\-:/])")
_TAG = re.compile(r"(<code>.*?</code>|<[^>]+>)", re.S)


def nobreak_numbers(cell: str) -> str:
    """Wrap each number of a cell's HTML in a span that never breaks across lines.

    Text inside tags and ``<code>`` (hashes) is left as it is.
    """
    parts = _TAG.split(cell)
    return "".join(p if i % 2 else _NUMBER.sub(lambda m: _num_raw(m.group(0)), p)
                   for i, p in enumerate(parts))


def _num_raw(text: str) -> str:
    return f"<span class='n'>{text}</span>"


def _table(header: list[str] | None, rows: list[list], cls: str = "") -> str:
    """Write a table (cells' numbers never break).

    With ``header``, each cell carries its column's name for the phone layout (the CSS
    shows it beside the value when the table reflows).
    """
    head = "" if not header else (
        "<thead><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in header)
        + "</tr></thead>")
    labels = header or []

    def cell(i: int, c) -> str:
        text = c if isinstance(c, _Raw) else _fmt(c)
        if "class='n'" not in text:
            text = nobreak_numbers(text)
        label = f" data-label='{html.escape(labels[i])}'" if i < len(labels) else ""
        return f"<td{label}>{text}</td>"

    body = "".join("<tr>" + "".join(cell(i, c) for i, c in enumerate(r)) + "</tr>"
                   for r in rows)
    return f"<table class='{cls}'>{head}<tbody>{body}</tbody></table>"


class _Raw(str):
    """Already formatted (and escaped) cell text."""


def _img(uri: str, alt: str) -> str:
    return f'<img src="{uri}" alt="{html.escape(alt)}">'


def _facts(r: ReportInputs) -> list[list]:
    v = r.verdict
    status = status_of(v)
    p = p_value(v)
    facts: list[list] = [["Decision", _Raw({"altered": "<b>altered</b>", "not_altered":
                                            "not altered", "inconclusive":
                                            "no verdict (inconclusive)"}[status])]]
    for reason in v.get("reasons") or []:
        facts.append(["Reason", reason])
    facts += _finding_facts(v.get("finding"))
    if status == "inconclusive":  # the two tests cannot be compared: no statistic means much
        return facts
    facts += _chance_facts(v, p)
    finding = v.get("finding") or {}
    read = finding.get("reading") or {}
    given = set(read) & set(finding.get("uncertainty") or {})  # shown with the finding
    if v.get("region_in") and not finding.get("region_in"):  # else the finding's rows say it
        facts.append(["Altered region (in from the knob end)",
                      _Raw(f"{v['region_in'][0]:.2f} – {v['region_in'][1]:.2f}")])
    if v.get("core_diameter_in") is not None and "core_diameter_in" not in read:
        facts.append(["Bore diameter (in)", _Raw(f"{v['core_diameter_in']:.2f}")])
    if v.get("fill_density_ratio") is not None and "fill_density_ratio" not in read:
        facts.append(["Fill density / wood density", _Raw(f"{v['fill_density_ratio']:.2f}")])
    names = {"stiffness_scale": "stiffness", "density_scale": "density"}
    for k, val in (v.get("moisture") or {}).items():
        if isinstance(val, (int, float)):
            facts.append([f"Whole-bat {names.get(k, k)} change (moisture, temperature), %",
                          _Raw(f"{100 * (val - 1):+.2f}")])
    for k, val in (v.get("uncertainty") or {}).items():
        if not isinstance(val, (int, float)) or set(lab_units({k: val})) & given:
            continue
        if k.endswith("_m"):
            facts.append([f"Uncertainty (1σ) of {k[:-2].replace('_', ' ')} (in)",
                          _Raw(f"±{val / IN_TO_M:.2g}")])
        elif k.endswith("_scale"):
            facts.append([f"Uncertainty (1σ) of whole-bat {names.get(k, k)} change, %",
                          _Raw(f"±{100 * val:.2g}")])
        else:
            facts.append([f"Uncertainty (1σ) of {k.replace('_', ' ')}", _Raw(f"±{val:.2g}")])
    stat = v.get("statistic")
    if stat is not None:
        fit_evidence = stored_details(v).fit
        name = (fit_evidence.statistic if fit_evidence else None) or "test statistic"
        facts.append([_Raw("Test statistic <span class='note'>(larger: further beyond what "
                           "moisture explains; the p-value above is what it means)</span>"),
                      _Raw(f"{stat:.4g} <span class='note'>{html.escape(str(name))}</span>")])
    return facts


def _chance_facts(v: dict, p: float | None) -> list[list]:
    """Return the evidence table's rows for the chance and the false-alarm rate.

    The chance as measured on the bat model's calibration (how many clean re-tests, how many
    at least as different, the record), or said unmeasured; the F distribution's nominal
    p-value beside it, named as nominal; the false-alarm rate measured or unmeasured; the
    decision's level.
    """
    ch = stated_chance(v) or {}
    rows: list[list] = []
    head = _Raw("Chance an unaltered bat differs this much <span class='note'>(how often a "
                "re-test of an unaltered bat differs at least this much from its "
                "baseline)</span>")
    cal = ch.get("calibration") if ch.get("source") == "calibration" else None
    if cal and ch.get("value") is not None:
        n, b = int(cal["n"]), int(cal["exceeding"])
        text = f"below 1 in {n + 1:,}" if b == 0 else share(float(ch["value"]))
        rows.append([head, _Raw(f"{html.escape(text)} <span class='note'>(measured: {b:,} of "
                                f"{n:,} clean re-tests at least this different)</span>")])
        rows.append(["Measured on (calibration)",
                     f"bat model {cal['model']}: {n:,} clean re-tests, custody record "
                     f"#{cal['record_seq']}, judged by batlab {cal.get('code')}"])
        if ch.get("extrapolated") is not None:
            rows.append(["Beyond the measured range (generalized-Pareto tail fit: an "
                         "extrapolation, not a measurement)", f"{ch['extrapolated']:.2g}"])
    elif ch.get("value") is not None:
        rows.append([head, _Raw("unmeasured <span class='note'>("
                                f"{html.escape(str(ch.get('unmeasured') or 'no calibration'))}"
                                ")</span>")])
    if p is not None:
        shown = "p < 0.000001" if p < 1e-6 else f"p = {p:.2g}"
        rows.append([_Raw("Nominal chance <span class='note'>(the F distribution's p-value: "
                          "not a measured rate)</span>"),
                     _Raw(f"{percent(p)} <span class='note'>({shown})</span>")])
    rate = false_alarm_words(v.get("false_alarm_rate"))
    if rate is not None:
        rows.append(["False-alarm rate", rate])
    return rows


READING_UNITS = {"_g": ("g", 1), "_in": ("in", 3), "_pct": ("%", 1)}
"""The contract's reading suffixes: the unit the evidence table names and its decimals."""


def _finding_facts(finding: dict | None) -> list[list]:
    """Return the evidence table's rows for the verdict's finding (contract ``finding``).

    What the change is in the rule's words (its kind, and whether legal), where, and each
    number of its reading with its standard uncertainty (1 sigma) when the verdict gives one.
    """
    if not finding:
        return []
    legal = ", legal under Rule 3.02(c)" if finding.get("legal") else ""
    rows: list[list] = [["Finding (the rule's words)",
                         f"{finding.get('rule')} ({finding.get('kind', '').replace('_', ' ')}"
                         f"{legal})"]]
    if finding.get("region_in"):
        a, b = finding["region_in"]
        rows.append(["Finding region (in from the knob end)", _Raw(f"{a:.2f} – {b:.2f}")])
    unc = finding.get("uncertainty") or {}
    for key, val in (finding.get("reading") or {}).items():
        if not isinstance(val, (int, float)):
            continue
        sfx = next((s for s in READING_UNITS if key.endswith(s)), "")
        unit, decimals = READING_UNITS.get(sfx, ("", 3))
        name = key[: -len(sfx)] if sfx else key
        u = unc.get(key)
        text = gum(val, float(u) if isinstance(u, (int, float)) else None, decimals)
        rows.append([f"Finding: {name.replace('_', ' ')}" + (f" ({unit})" if unit else ""),
                     _Raw(_num(text))])
    return rows


def _provenance(r: ReportInputs) -> list[list]:
    pv, meta = r.provenance, r.meta
    judged = r.verdict.get("code") or pv.get("batlab_version")
    drawn = code_version()
    rows: list[list] = [["Code that judged (batlab version)", judged],
                        ["Code that drew this report", drawn]]
    if judged != drawn:
        rows.append(["Other code", f"judged by batlab {judged}, this report drawn by batlab "
                                   f"{drawn}: the verdict and its chance are as stored; the "
                                   "figures are refitted (and a missing element map judged "
                                   "again) by the code that drew it"])
    if pv.get("inspection_id") is not None:
        when = pv["inspected_at"][:19].replace("T", " ")
        rows.append(["Inspected (UTC)", when])
    if meta.get(FORCED_KEY):
        rows.append(["Registered with --force", str(meta[FORCED_KEY])])
    rows.append(["Calibrated wood: E (psi), density (lb/in³), E/G", _Raw(
        f"{significant(r.reference.E_pa / PSI_TO_PA, 3)}, "
        f"{significant(r.reference.rho_kg_m3 / LBF_IN3_TO_KG_M3, 3)}, "
        f"{r.reference.e_over_g:.1f}")])
    for label, name, key in (("Baseline file", r.baseline.name, "baseline_sha256"),
                             ("Re-test file", r.retest.name, "retest_sha256")):
        sha = pv.get(key)
        rows.append([label, _Raw(f"{html.escape(name)}<br><code>sha256 {sha or '—'}</code>")])
    for label, key in (("Verdict record", "verdict_record"),
                       ("Registration record", "reference_record")):
        if pv.get(key) is not None:
            rows.append([label, _Raw(f"#{pv[key]}<br><code>sha256 "
                                     f"{pv[key + '_sha256']}</code>")])
    if pv.get("chain_head"):
        rows.append(["Registry head when written", _Raw(f"<code>{pv['chain_head']}</code>")])
    return rows


def verdict_box_html(v: dict, weighed: bool = False) -> str:
    """Write the first screen (``batlab.verdict_box``) as the coloured verdict box."""
    lines = "".join(
        f"<p>{f'<b>{html.escape(label)}:</b> ' if label else ''}{html.escape(text)}</p>"
        for label, text in verdict_box(v, weighed).lines())
    return f"<div class='verdict {status_of(v)}'>{lines}</div>"


def render_html(r: ReportInputs, generated_at: str, figures: dict[str, bytes],
                lab: dict | None = None) -> str:
    """Render the report page as a string.

    ``figures``: name -> PNG bytes (``figures_png``); ``lab``: the lab profile
    (``batlab.lab.read_lab``) for the certificate block, None when there is none.
    """
    v = r.verdict
    number = report_number(r)
    parts = [f"<h1>Inspection of bat {html.escape(r.serial)}</h1>",
             f"<p class='note'>Report {html.escape(number)}</p>",
             verdict_box_html(v, (r.conditions or {}).get("weight_kg") is not None),
             f"<p class='finding'>{html.escape(headline(r))}</p>",
             *([f"<p class='warn'>This bat was registered with --force although its baseline "
                f"looked odd: {html.escape(str(r.meta[FORCED_KEY]))}</p>"]
               if r.meta.get(FORCED_KEY) else []),
             "<h2>Certificate</h2>",
             _table(None, certificate_rows(r, lab, generated_at), "facts certificate"),
             "<h2>The evidence</h2>", _table(None, _facts(r), "facts")]
    weights = weight_rows(r)
    if weights:
        parts += ["<h2>Weight, by source</h2>",
                  _table(["Source", "Weight change (g)", "Weight change (%)", "How"],
                         weights, "wide")]
        agree = weights_agree(r)
        if agree:
            parts.append(f"<p>{html.escape(agree)}</p>")
    parts.append("<h2>Where the bat changed</h2>")
    parts.append(_img(_data_uri(figures["elements"]), "element changes over the bat profile"))
    note = regions_note(r)
    if note:
        parts.append(f"<p>{html.escape(note)}</p>")
    parts.append("<p class='note'>Solid bars: the fitted change (what the verdict found) of "
                 "each element's mass (alpha) and bending stiffness (beta), as fractions "
                 "(M = M_S + Σ alpha_i m_i, K = K_S + Σ beta_i k_i). Blue: the element gained "
                 "(mass added, stiffer); orange: it lost (mass removed, softer). Hatched bars: "
                 "the element map (MSSO) of the re-test against the baseline-updated model "
                 "with the whole-bat drift and sensor shift removed; its stiffness bars also "
                 "carry a bore's shear loss, so they are larger than the bending ratio. Grey: "
                 "the map's ±2σ noise band; a bar inside it is not a change and is drawn "
                 "faded. Shaded: the finding's region, named by its kind. One symmetric scale "
                 "for every bar of both panels, at least ±5 %.</p>")
    parts.append("<h2>Mass properties</h2>")
    rows = mass_rows(r)
    w0, cg0, i0 = rows[0][1:]
    parts.append(_table(
        ["Model", "Weight (lb)", "Balance point from the knob (in)",
         "Shift (in)", "Swing weight about the knob (lb in²)", "Change (%)"],
        [[label, _Raw(f"{w:.3f}"), _Raw(f"{cg:.2f}"),
          _Raw(f"{cg - cg0:+.3f}"), _Raw(f"{i:.0f}"), _Raw(f"{100 * (i / i0 - 1):+.2f}")]
         for label, w, cg, i in rows], "wide"))
    modes = [jsonable(ModePair.from_json_dict(m).to_json_dict()) for m in v.get("modes") or []]
    if modes:
        keys = list(dict.fromkeys(k for m in modes for k in m))
        parts.append("<h2>Paired modes</h2>")
        parts.append(_table([_label(k) for k in keys],
                            [[_Raw(_mode_cell(k, m.get(k))) for k in keys] for m in modes],
                            "modes wide"))
    parts.append("<h2>Test data</h2>")
    parts.append(_img(_data_uri(figures["frf"]), "driving-point FRF overlay"))
    parts.append(_img(_data_uri(figures["mac"]), "MAC baseline vs re-test"))
    for key, name in (("stabilisation_baseline", r.baseline.name),
                      ("stabilisation_retest", r.retest.name)):
        if key in figures:
            parts.append(f"<h3>Stabilisation diagram: {html.escape(name)}</h3>")
            parts.append(_img(_data_uri(figures[key]), f"stabilisation {name}"))
    parts.append("<h2>Provenance</h2>")
    parts.append(_table(None, _provenance(r), "facts"))
    if r.provenance.get("verdict_record") is not None:
        parts.append("<p class='note'>To verify: <code>batlab registry check --report "
                     "index.html</code> on the registry confirms every record is unchanged and "
                     "that this page's records and files are the registry's; <code>batlab "
                     f"history {html.escape(r.serial)} --json</code> shows these hashes; a "
                     "file's <code>sha256sum</code> must equal its hash above.</p>")
    page_css = ("@page{size:A4;margin:16mm 12mm 18mm;@top-left{content:'batlab report "
                f"{number}';font-size:9pt;color:#555}}@bottom-right{{content:'Page ' "
                "counter(page) ' of ' counter(pages);font-size:9pt;color:#555}}")
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>batlab inspection {html.escape(r.serial)}: report {html.escape(number)}"
            f"</title><style>{CSS}{page_css}</style></head><body>" + "\n".join(parts)
            + "</body></html>\n")


def figures_png(r: ReportInputs) -> dict[str, bytes]:
    """Every figure of the report as PNG bytes, by name (the file name under ``--plots``)."""
    import matplotlib

    matplotlib.use("Agg")
    out = {"elements": _png_bytes(element_figure(r)), "frf": _png_bytes(frf_figure(r)),
           "mac": _png_bytes(mac_figure(r))}
    for key, ft in (("stabilisation_baseline", r.baseline), ("stabilisation_retest", r.retest)):
        if ft.fit is not None and getattr(ft.fit, "sweep", None) is not None:
            out[key] = stabilisation_png(ft.fit)
    return out


def check_destination(out_dir: str | os.PathLike, what: str = "report") -> Path:
    """Check a report destination.

    Create ``out_dir`` if needed and prove it writable (a probe file created and removed),
    before any work: ValueError naming it otherwise.
    """
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ValueError(f"{out_dir}: {what} destination is not a directory")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=out_dir, prefix=".batlab-probe-"):
            pass
    except OSError as exc:
        raise ValueError(f"{out_dir}: {what} destination not writable "
                         f"({exc.strerror or exc})") from None
    return out_dir


def write_plots(plots_dir: str | os.PathLike, r: ReportInputs,
                figures: dict[str, bytes] | None = None) -> Path:
    """Each figure of the report as ``plots_dir/<name>.png``."""
    plots_dir = check_destination(plots_dir, "plots")
    for name, png in (figures or figures_png(r)).items():
        atomic_write(plots_dir / f"{name}.png", lambda tmp, png=png: tmp.write_bytes(png))
    return plots_dir


def write_report(
    out_dir: str | os.PathLike, r: ReportInputs, plots_dir: str | os.PathLike | None = None,
    generated_at: str | None = None,
) -> Path:
    """Write the report.

    Write ``out_dir/index.html`` (temporary file, then rename) and, with ``plots_dir``, each
    figure as ``plots_dir/<name>.png``; returns the page's path.
    """
    out_dir = check_destination(out_dir)
    if plots_dir is not None:
        plots_dir = check_destination(plots_dir, "plots")
    from batlab.lab import read_lab

    lab = read_lab()
    figures = figures_png(r)
    page = for_page(render_html(r, generated_at or now_utc(), figures, lab))  # no NUL
    if r.provenance.get("verdict_record") is not None:
        page = seal_page(page)
    path = out_dir / "index.html"
    atomic_write(path, lambda tmp: tmp.write_text(page, encoding="utf-8"))
    if plots_dir is not None:
        write_plots(plots_dir, r, figures)
    return path


CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome")
"""The browsers ``find_chromium`` looks for on PATH (Debian's package installs
``/usr/bin/chromium``)."""


def find_chromium(env: dict | None = None) -> str:
    """Return the Chromium that prints the PDF.

    ``$BATLAB_CHROMIUM``, else the first of ``CHROMIUM_NAMES`` on PATH; ValueError with how
    to install it when there is none.
    """
    import shutil

    env = os.environ if env is None else env
    if env.get("BATLAB_CHROMIUM"):
        return env["BATLAB_CHROMIUM"]
    for name in CHROMIUM_NAMES:
        found = shutil.which(name, path=env.get("PATH"))
        if found:
            return found
    raise ValueError("--pdf needs Chromium to print the page and none was found on PATH "
                     "(apt-get install chromium, or set BATLAB_CHROMIUM)")


def write_pdf(page: Path, pdf: Path | None = None, timeout_s: float = 120.0) -> Path:
    """Print a report page to PDF with headless Chromium (``--print-to-pdf``).

    The page's print stylesheet sets A4, the report number on every page and "Page x of y";
    Chromium's own header and footer are left out. Written to a temporary file and renamed.

    Parameters
    ----------
    page : Path
        The report's ``index.html``.
    pdf : Path or None
        Where to write; default ``report.pdf`` beside the page.
    timeout_s : float
        How long Chromium may take, s.

    Returns
    -------
    Path
        The PDF's path.
    """
    import subprocess

    browser = find_chromium()
    pdf = Path(pdf) if pdf is not None else page.parent / "report.pdf"
    with tempfile.TemporaryDirectory(prefix="batlab-pdf-") as tmp:
        out = Path(tmp) / "report.pdf"
        cmd = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
               "--disable-background-networking", "--disable-component-update",
               "--disable-sync", f"--user-data-dir={tmp}/profile", "--no-pdf-header-footer",
               f"--print-to-pdf={out}", page.resolve().as_uri()]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s)
        except (OSError, subprocess.TimeoutExpired) as exc:
            raise ValueError(f"{browser}: could not print the PDF ({exc})") from None
        if done.returncode != 0 or not out.exists() or out.stat().st_size == 0:
            tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
            raise ValueError(f"{browser}: could not print the PDF (exit {done.returncode}: "
                             f"{tail})")
        atomic_write(pdf, lambda t: t.write_bytes(out.read_bytes()))
    return pdf
