"""Readable forms of a diagnosis: the ranked table and the per-mode error plot."""

from __future__ import annotations

import textwrap
from pathlib import Path


def format_table(out: dict) -> str:
    """Write the diagnose JSON object as text: modes, RMS errors, causes, calibrated values."""
    lines = [f"bat {out.get('serial', '')}".rstrip(),
             "mode  measured_hz  nominal_hz  error_%  extended_hz  error_%    MAC"]
    for i, m in enumerate(out["modes"], 1):
        f = m["measured_hz"]
        lines.append(f"{i:4d}  {f:11.1f}  {m['nominal_hz']:10.1f}  "
                     f"{100 * (m['nominal_hz'] / f - 1):+7.2f}  {m['extended_hz']:11.1f}  "
                     f"{100 * (m['extended_hz'] / f - 1):+7.3f}  {m['mac']:.3f}")
    rms = out["rms_error_pct"]
    lines.append(f"RMS frequency error: nominal {rms['nominal']:.2f} %, "
                 f"extended {rms['extended']:.3f} %")
    lines.append("causes (largest gain first):")
    if not out["causes"]:
        lines.append("  none above the threshold")
    for c in out["causes"]:
        unc = c.get("uncertainty", {})
        vals = ", ".join(f"{k} {_num(v)}" + (f" +- {unc[k]:.2g}" if unc.get(k) else "")
                         for k, v in c["value"].items())
        lines.append(f"  {c['name']:<18} gain {c['gain_pct']:6.3f} pp   {vals}")
    quiet = [n for n in out.get("not_named", []) if n.get("in_reference")]
    if quiet:
        text = ("also in the calibrated model (frequency gain too small to name): "
                + ", ".join(f"{n['name']} ({n['gain_pct']:+.3f} pp)" for n in quiet))
        lines += textwrap.wrap(text, 96, subsequent_indent="  ")
    cal = out["calibrated"]
    lines.append(f"calibrated: E {cal['E_psi']:.4g} psi, E/G {cal['E_over_G']:.3g}, weight "
                 f"density {cal['weight_density_lbf_in3']:.5f} lbf/in^3, sensor "
                 f"{cal['sensor_mass_g']:.2f} g")
    if cal.get("E_over_G_plane2") is not None:
        lines.append(f"second bending plane: E/G {cal['E_over_G_plane2']:.3g}, tapped at "
                     f"{cal['tap_angle_deg']:.1f} deg from the first")
    for w in out.get("warnings", []):
        lines += textwrap.wrap("warning: " + w, 96, subsequent_indent="  ")
    return "\n".join(lines)


def _num(v) -> str:
    """Write a value of the JSON as text: numbers to 4 digits, lists element-wise."""
    if isinstance(v, bool) or isinstance(v, str):
        return str(v)
    if isinstance(v, (list, tuple)):
        return "[" + " ".join(_num(x) for x in v) + "]"
    return f"{v:.4g}"


def write_plot(result, path: Path, title: str = "") -> Path:
    """Bar chart of the percent frequency error per mode, nominal vs calibrated (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ema.io.atomic_write import atomic_write

    f = result.measured_hz
    nominal = 100 * (result.nominal.model_hz / f - 1)
    extended = 100 * (result.extended.model_hz / f - 1)
    x = np.arange(f.size)
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(6.4, 5.2), sharex=True)
    ax1.bar(x, nominal, color="tab:red", label=f"nominal (RMS {result.nominal.rms_pct:.2f} %)")
    ax1.set_ylabel("error, %")
    ax1.legend(loc="upper left", fontsize=8)
    ax2.bar(x, extended, color="tab:green",
            label=f"calibrated (RMS {result.extended.rms_pct:.3f} %)")
    ax2.set_ylabel("error, %")
    ax2.legend(loc="best", fontsize=8)
    ax2.set_xticks(x, [f"{v:.0f} Hz" for v in f], fontsize=8)
    ax2.set_xlabel("measured mode")
    for ax in (ax1, ax2):
        ax.axhline(0.0, color="k", lw=0.6)
        ax.grid(axis="y", alpha=0.3)
    names = ", ".join(f"{c.name} {c.gain_pct:.2f}" for c in result.causes) or "none"
    fig.suptitle(f"{title} model error per mode; causes (pp): {names}".strip(), fontsize=9)
    fig.tight_layout()
    atomic_write(path, lambda tmp: fig.savefig(tmp, format="png", dpi=90))
    plt.close(fig)
    return path
