"""The inspection report: one self-contained HTML page (figures embedded as base64 PNG).

Contents: the verdict and its confidence; driving-point FRFs of the baseline and the re-test
with the re-test's modal synthesis; stabilisation diagrams of both fits; MAC of baseline vs
re-test modes; element mass (alpha) and stiffness (beta) factors as bars over a to-scale drawing
of the bat (the paper's Figures 2 and 3 for this bat); and the mass-property change implied by
the element factors and by the fitted core. Layout: docs/report.md.
"""

from __future__ import annotations

import base64
import html
import io
import os
import tempfile
from pathlib import Path

import numpy as np

from batlab.pipeline import InspectionResult, contract_dict
from ema.io.atomic_write import atomic_write
from updating.model.mass_properties import MassProperties, mass_properties
from updating.model.sections import Core
from updating.model.units import IN_TO_M, KG_M2_TO_LB_IN2, LB_TO_KG


def _data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _png(fig) -> str:
    """A figure as a base64 PNG data URI (the figure is closed)."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return _data_uri(buf.getvalue())


def stabilisation_png(fit) -> str:
    """The fit's stabilisation diagram (``ema.plots.plot_stabilisation``) as a data URI."""
    from ema.plots import plot_stabilisation

    with tempfile.TemporaryDirectory(prefix="batlab-report-") as tmp:
        return _data_uri(plot_stabilisation(fit, Path(tmp) / "stab.png").read_bytes())


def _db(h: np.ndarray) -> np.ndarray:
    return 20 * np.log10(np.maximum(np.abs(h), 1e-300))


def frf_figure(result: InspectionResult):
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


def mac_figure(result: InspectionResult):
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


def element_figure(result: InspectionResult):
    """alpha and beta per element as bars, over the bat's profile drawn to scale (inches):
    the physical fit's factors (how much; left half of each element, left axis) beside the
    MSSO map (where; right half, hatched, right axis), each region shaded."""
    import matplotlib.pyplot as plt

    v, prof = result.verdict, result.profile
    x0, x1 = np.asarray(v.element_x0_m) / IN_TO_M, np.asarray(v.element_x1_m) / IN_TO_M
    w = x1 - x0
    length_in = prof.length_m / IN_TO_M
    d_max = float(prof.diameter_m.max()) / IN_TO_M
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(10, 6.8),
                             gridspec_kw={"height_ratios": [2.2, 2.2, 1.0]})
    region = v.region_m if v.altered else None
    msso = (v.details or {}).get("msso") or {}
    has_map = "alpha" in msso and len(msso["alpha"]) == len(x0)
    for ax, vals, key, name, color in ((axes[0], v.alpha, "alpha", "alpha (mass)", "C0"),
                                       (axes[1], v.beta, "beta", "beta (stiffness)", "C1")):
        ax.bar(x0, np.asarray(vals), width=w / 2 if has_map else w, align="edge", color=color,
               edgecolor="k", lw=0.4, label="physical core fit (how much)")
        ax.axhline(0, color="k", lw=0.6)
        ax.set_ylabel(name)
        ax.grid(alpha=0.3, axis="y")
        if region is not None:
            ax.axvspan(region[0] / IN_TO_M, region[1] / IN_TO_M, color="C3", alpha=0.12)
        if has_map:
            ax2 = ax.twinx()
            vm = np.asarray(msso[key])
            ax2.bar(x0 + w / 2, vm, width=w / 2, align="edge", color="none", edgecolor="C2",
                    hatch="////", lw=0.6, label="MSSO map (where)")
            lim = 1.1 * max(float(np.max(np.abs(vm))), 1e-6)
            ax2.set_ylim(-lim, lim)
            ax2.set_ylabel(f"{key}, MSSO map", color="C2")
            ax2.tick_params(axis="y", colors="C2")
            if msso.get("region_m"):
                a, b = msso["region_m"]
                ax2.axvspan(a / IN_TO_M, b / IN_TO_M, fill=False, hatch="..", color="C2",
                            alpha=0.25, lw=0)
            lo, hi = ax.get_ylim()
            m = max(abs(lo), abs(hi), 1e-6)
            ax.set_ylim(-m, m)  # both zero lines at the same height
            if key == "alpha":
                h1, l1 = ax.get_legend_handles_labels()
                h2, l2 = ax2.get_legend_handles_labels()
                ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper left")
    axes[0].set_title("Element factors along the bat (knob at 0)")
    ax = axes[2]
    x = prof.x_m / IN_TO_M
    r = prof.diameter_m / IN_TO_M / 2
    ax.fill_between(x, -r, r, color="burlywood", edgecolor="saddlebrown", lw=0.8)
    if region is not None and v.core_diameter_m:
        rc = v.core_diameter_m / IN_TO_M / 2
        a, b = region[0] / IN_TO_M, region[1] / IN_TO_M
        ax.add_patch(plt.Rectangle((a, -rc), b - a, 2 * rc, color="C3", alpha=0.7,
                                   label="fitted core"))
        ax.legend(fontsize=8, loc="lower left")
    pts = result.baseline.modes.x_m / IN_TO_M
    ax.plot(pts, np.zeros_like(pts), "k+", ms=5, label="test points")
    ax.set_aspect("equal")
    ax.set_ylim(-0.75 * d_max, 0.75 * d_max)
    ax.set_xlim(-0.5, length_in + 0.5)
    ax.set_xlabel("x from the knob end (in)")
    ax.set_ylabel("in")
    fig.tight_layout()
    return fig


# --- mass properties ---------------------------------------------------------------------------


def element_mass_change(result: InspectionResult, n_quad: int = 24) -> MassProperties:
    """Mass, first and second moments added by the element factors, as a MassProperties of the
    change: dm = sum alpha_e int rho A dx, d(m x_cg) = sum alpha_e int rho A x dx,
    dI_knob = sum alpha_e int (rho A x^2 + rho I) dx, I = pi D^4 / 64 (the section's own
    rotary inertia, as in ``updating.model.mass_properties``);
    cg_m holds d(m x_cg) / dm, i_cg is 0."""
    v, prof = result.verdict, result.profile
    rho = result.reference.rho_kg_m3
    x0, x1 = np.asarray(v.element_x0_m), np.asarray(v.element_x1_m)
    t, w = np.polynomial.legendre.leggauss(n_quad)
    half = (x1 - x0)[:, None] / 2
    xq = (x0 + x1)[:, None] / 2 + half * t[None, :]
    wq = half * w[None, :]
    dq = prof.diameter_at(xq)
    rho_a = rho * np.pi / 4 * dq**2
    rho_i = rho * np.pi / 64 * dq**4
    alpha = np.asarray(v.alpha)[:, None]
    dm = float(np.sum(alpha * wq * rho_a))
    dmx = float(np.sum(alpha * wq * rho_a * xq))
    di = float(np.sum(alpha * wq * (rho_a * xq**2 + rho_i)))
    return MassProperties(dm, dmx / dm if dm else 0.0, di, 0.0)


def mass_rows(result: InspectionResult) -> list[tuple[str, float, float, float]]:
    """(label, weight lb, centre of mass in, I_knob lb in^2): reference, with the element
    factors applied, with the fitted core."""
    ref = mass_properties(result.reference.build(result.profile))
    rows = [("reference (baseline)", ref.mass_kg, ref.cg_m, ref.i_knob_kg_m2)]
    d = element_mass_change(result)
    m = ref.mass_kg + d.mass_kg
    rows.append(("with the element factors", m, (ref.mass_kg * ref.cg_m + d.mass_kg * d.cg_m) / m,
                 ref.i_knob_kg_m2 + d.i_knob_kg_m2))
    v = result.verdict
    if v.altered and v.region_m and v.core_diameter_m and v.fill_density_ratio is not None:
        length = result.profile.length_m
        core = Core(v.core_diameter_m, length - v.region_m[0], v.fill_density_ratio,
                    plug_m=max(length - v.region_m[1], 0.0))
        c = mass_properties(result.reference.build(result.profile, core=core))
        rows.append(("with the fitted core", c.mass_kg, c.cg_m, c.i_knob_kg_m2))
    return [(label, mk / LB_TO_KG, cg / IN_TO_M, i * KG_M2_TO_LB_IN2)
            for label, mk, cg, i in rows]


# --- page ------------------------------------------------------------------------------------

CSS = """
body{font-family:system-ui,Segoe UI,Helvetica,Arial,sans-serif;max-width:1000px;margin:24px auto;
color:#222;padding:0 12px}
h1{margin-bottom:4px}.verdict{font-size:1.5em;padding:12px 16px;border-radius:6px;margin:12px 0}
.altered{background:#fde2e1;border:2px solid #c0392b}
.clean{background:#e3f5e1;border:2px solid #27ae60}
table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #ccc;padding:3px 8px;
text-align:right}th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}
img{max-width:100%;display:block;margin:8px 0}.wide{overflow-x:auto}.note{color:#666;font-size:.9em}
"""


def _fmt(v, spec: str = ".4g") -> str:
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int, float, np.floating, np.integer)):
        return format(float(v), spec)
    return html.escape(str(v))


def _table(header: list[str], rows: list[list]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{_fmt(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f"<div class='wide'><table><tr>{head}</tr>{body}</table></div>"


def _img(uri: str, alt: str) -> str:
    return f'<img src="{uri}" alt="{html.escape(alt)}">'


def render_html(result: InspectionResult) -> str:
    """The report page as a string."""
    import matplotlib

    matplotlib.use("Agg")
    out = contract_dict(result.serial, result.verdict)
    v = result.verdict
    cls = "altered" if out["altered"] else "clean"
    decision = "ALTERED" if out["altered"] else "not altered"
    conf = out["confidence"]
    parts = [f"<h1>Inspection of bat {html.escape(result.serial)}</h1>",
             f"<p class='note'>baseline {html.escape(result.baseline.name)}, re-test "
             f"{html.escape(result.retest.name)}</p>",
             f"<div class='verdict {cls}'>{decision}"
             + ("" if conf is None else f" &mdash; confidence {conf:.3f}") + "</div>"]
    facts = [["decision", out["altered"]], ["confidence (1 - p)", conf],
             ["false-alarm rate", out["false_alarm_rate"]], ["test statistic", v.statistic]]
    if out["region_in"]:
        facts.append(["altered region (in from the knob)",
                      f"{out['region_in'][0]:.2f} – {out['region_in'][1]:.2f}"])
    facts += [["core diameter (in)", out["core_diameter_in"]],
              ["fill density / wood density", out["fill_density_ratio"]]]
    for k, val in (v.moisture or {}).items():
        facts.append([f"uniform drift: {k}", val])
    for k, val in (v.uncertainty or {}).items():
        if k.endswith("_m") and isinstance(val, (int, float)):  # lengths shown in inches
            k, val = k[:-2] + "_in", val / IN_TO_M
        facts.append([f"standard uncertainty: {k}", val])
    parts.append(_table(["quantity", "value"], facts))

    parts.append("<h2>Element changes along the bat</h2>")
    parts.append(_img(_png(element_figure(result)), "element factors over the bat profile"))
    msso = (v.details or {}).get("msso") or {}
    if "error" in msso:
        parts.append(f"<p class='note'>MSSO map not available: {html.escape(msso['error'])}</p>")
    elif "alpha" in msso:
        reg = msso.get("region_m")
        where = ("no significant local change" if not reg else
                 f"changed region {reg[0] / IN_TO_M:.1f} – {reg[1] / IN_TO_M:.1f} in")
        parts.append(
            "<p class='note'>Solid bars, left axis: the element ratios of the fitted core (how "
            "much; the contract's elements). Hatched bars, right axis: the MSSO map of the "
            "re-test against the baseline-updated reference with the fitted moisture and sensor "
            f"shift removed (where; {where}, peak z {msso.get('peak_z', 0):.1f}, "
            f"{'agrees' if msso.get('agrees_with_fit') else 'disagrees'} with the fit). Its "
            "stiffness bars also carry the core's shear loss, so they are larger than the "
            "bending ratio.</p>")
    parts.append("<h2>Mass properties</h2>")
    rows = mass_rows(result)
    w0, cg0, i0 = rows[0][1:]
    parts.append(_table(
        ["model", "weight (lb)", "change (%)", "centre of mass (in)", "shift (in)",
         "I knob (lb in²)", "change (%)"],
        [[label, w, 100 * (w / w0 - 1), cg, cg - cg0, i, 100 * (i / i0 - 1)]
         for label, w, cg, i in rows]))
    if v.modes:
        keys = list(dict.fromkeys(k for m in v.modes for k in m))
        parts.append("<h2>Paired modes</h2>")
        parts.append(_table(keys, [[m.get(k) for k in keys] for m in v.modes]))

    parts.append("<h2>Test data</h2>")
    parts.append(_img(_png(frf_figure(result)), "driving-point FRF overlay"))
    parts.append(_img(_png(mac_figure(result)), "MAC baseline vs re-test"))
    for ft in (result.baseline, result.retest):
        if ft.fit is not None and getattr(ft.fit, "sweep", None) is not None:
            parts.append(f"<h3>Stabilisation diagram: {html.escape(ft.name)}</h3>")
            parts.append(_img(stabilisation_png(ft.fit), f"stabilisation {ft.name}"))
    parts.append("<p class='note'>Made by batlab; element factors: M = M_S + sum alpha_i m_i, "
                 "K = K_S + sum beta_i k_i (MSSO).</p>")
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>batlab inspection {html.escape(result.serial)}</title>"
            f"<style>{CSS}</style></head><body>" + "\n".join(parts) + "</body></html>\n")


def write_report(out_dir: str | os.PathLike, result: InspectionResult) -> Path:
    """Write ``out_dir/index.html`` (temporary file, then rename); returns its path."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ValueError(f"{out_dir}: report destination is not a directory")
    page = render_html(result)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "index.html"
    atomic_write(path, lambda tmp: tmp.write_text(page, encoding="utf-8"))
    return path
