"""`batlab fit`: automatic experimental modal analysis of one FRF test file."""

from __future__ import annotations

import argparse
import json
import sys

from batlab.cli_support import add_out_argument, add_plots_argument, note_printer
from batlab.pipeline import IN_TO_M, KG_M2_TO_LB_IN2, LB_TO_KG, MIN_SNR

EXAMPLE = "batlab fit baseline.uff --json"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab fit`` to its sub-parser."""
    p.add_argument("test", help="FRF test file (.uff/.unv, .csv or .npz)")
    p.add_argument("--band", nargs=2, type=float, metavar=("LO_HZ", "HI_HZ"), default=None,
                   help="frequency band fitted, Hz (default: 20 Hz to the last line)")
    p.add_argument("--method", choices=("lscf", "peak"), default="lscf",
                   help="lscf: polyreference LSCF + automatic stabilisation (default); "
                        "peak: MIF peaks with half-power damping")
    p.add_argument("--max-order", type=int, default=None,
                   help="highest LSCF model order per sub-band (default 30)")
    p.add_argument("--refine", action="store_true",
                   help="refine the poles by maximum likelihood (slower; LS uncertainties)")
    p.add_argument("--min-snr", type=float, default=MIN_SNR,
                   help="support a mode needs: its contribution at resonance over the local "
                        f"misfit, divided by sqrt(max(1, zeta/1%%)) (default {MIN_SNR:g})")
    p.add_argument("--mass-kg", type=float, default=None,
                   help="the bat's mass, kg, for the mass-line scaling check")
    p.add_argument("--json", action="store_true", help="print the modes as JSON on stdout")
    add_plots_argument(p, "write stabilisation.png, synthesis.png and automac.png into DIR")
    add_out_argument(p, "write the real mass-normalised modes as UFF 55", "MODES.uff")


def _mode_rows(fit) -> list[dict]:
    rows = []
    for k in range(fit.freq_hz.size):
        rows.append({
            "frequency_hz": float(fit.freq_hz[k]),
            "damping_ratio": float(fit.damping_ratio[k]),
            "mpc": float(fit.mpc[k]),
            "mpd_deg": float(fit.mpd[k]),
            "shape": {
                "nodes": [int(n) for n in fit.nodes],
                "x_m": [float(x) for x in fit.x_m],
                "real": [float(v) for v in fit.shapes[:, k].real],
                "imag": [float(v) for v in fit.shapes[:, k].imag],
                "normal": [float(v) for v in fit.real_shapes[:, k]],
            },
            "uncertainty": {
                "frequency_std_hz": _num(fit.freq_std_hz[k]),
                "damping_std": _num(fit.damping_std[k]),
                "stable_orders": int(fit.stable_count[k]),
            },
            "warnings": list(fit.warnings[k]) if k < len(fit.warnings) else [],
        })
    return rows


def _num(v: float) -> float | None:
    return None if v != v else float(v)  # NaN -> null


def summary(fit) -> dict:
    """Build the JSON document of a fit (see docs/ema.md)."""
    rb = fit.rigid_body
    return {
        "method": fit.method,
        "band_hz": list(fit.band_hz),
        "quantity": fit.quantity,
        "driving_point_node": (None if fit.driving_index is None
                               else int(fit.nodes[fit.driving_index])),
        "scaled": bool(fit.scaled),
        "modes": _mode_rows(fit),
        "close_pairs": [
            {"modes": [c.i, c.j], "frequency_hz": [float(fit.freq_hz[c.i]),
                                                   float(fit.freq_hz[c.j])],
             "separation": c.separation, "modal_overlap": c.modal_overlap, "mac": c.mac}
            for c in fit.close_pairs
        ],
        "rejected": [
            {"frequency_hz": r.freq_hz, "damping_ratio": r.damping_ratio, "reason": r.reason,
             "detail": r.detail}
            for r in fit.rejected
        ],
        "notes": list(fit.notes),
        "decisions": [  # every candidate: kept (a mode) or dropped, and why
            {"frequency_hz": float(f), "kept": True,
             "reason": "own_peak" if "own peak" in why else "support", "detail": why}
            for f, why in zip(fit.freq_hz, fit.decisions, strict=False)
        ] + [{"frequency_hz": r.freq_hz, "kept": False, "reason": r.reason, "detail": r.detail}
             for r in fit.rejected],
        "synthesis_error": {
            "total": fit.synthesis_error_total,
            "per_frf": [float(v) for v in fit.synthesis_error.ravel()],
        },
        "suspension_modes": [
            {"frequency_hz": float(f), "damping_ratio": float(z)}
            for f, z in zip(fit.suspension_freq_hz, fit.suspension_damping_ratio, strict=True)
        ],
        "rigid_body": {
            "mass_kg": rb.mass_kg,
            "x_cg_m": rb.x_cg_m,
            "pitch_inertia_kg_m2": rb.pitch_inertia_kg_m2,
            "mass_lower_bound_kg": rb.mass_upper_bound_kg,
            # deprecated (it is a lower bound): kept one release beside mass_lower_bound_kg
            "mass_upper_bound_kg": rb.mass_upper_bound_kg,
        },
    }


def _table(fit) -> str:
    lines = [f"{fit.freq_hz.size} modes in {fit.band_hz[0]:g}-{fit.band_hz[1]:g} Hz "
             f"({fit.method}, {fit.quantity}); synthesis error "
             f"{fit.synthesis_error_total:.2%}",
             f"{'mode':>4s} {'f (Hz)':>10s} {'+-':>8s} {'zeta (%)':>9s} {'+-':>7s} "
             f"{'MPC':>7s} {'MPD deg':>8s} {'orders':>6s}"]
    for k in range(fit.freq_hz.size):
        fs, zs = fit.freq_std_hz[k], fit.damping_std[k]
        lines.append(
            f"{k + 1:4d} {fit.freq_hz[k]:10.3f} {fs:8.3f} {100 * fit.damping_ratio[k]:9.4f} "
            f"{100 * zs:7.4f} {fit.mpc[k]:7.4f} {fit.mpd[k]:8.2f} {fit.stable_count[k]:6d}"
        )
    rb = fit.rigid_body
    if fit.suspension_freq_hz.size:
        lines.append("suspension modes: " + ", ".join(
            f"{f:.2f} Hz" for f in fit.suspension_freq_hz))
    # lab units first (lb, in, lb in^2), SI in brackets (the file and --json are SI)
    if rb.mass_kg is not None:
        lines.append(
            f"rigid body from the scaling: weight {rb.mass_kg / LB_TO_KG:.4f} lb "
            f"({rb.mass_kg:.4f} kg), centre of mass {rb.x_cg_m / IN_TO_M:.2f} in from node x = 0 "
            f"({rb.x_cg_m:.4f} m), pitch inertia {rb.pitch_inertia_kg_m2 * KG_M2_TO_LB_IN2:.1f} "
            f"lb in^2 ({rb.pitch_inertia_kg_m2:.5f} kg m^2)")
    if rb.mass_upper_bound_kg is not None:
        lines.append(f"mass line at the driving point bounds the mass from below: "
                     f"M >= 1/a(x_d) = {rb.mass_upper_bound_kg / LB_TO_KG:.4f} lb "
                     f"({rb.mass_upper_bound_kg:.4f} kg)")
    return "\n".join(lines)


def explain(fit) -> list[str]:
    """Word the short stderr summary: notes, rejections by reason, warned modes, close pairs."""
    lines = [f"batlab fit: note: {n}" for n in fit.notes]
    counts: dict[str, list[float]] = {}
    for r in fit.rejected:
        counts.setdefault(r.reason, []).append(r.freq_hz)
    if counts:
        lines.append("batlab fit: rejected candidates: " + "; ".join(
            f"{len(v)} {k} (" + ", ".join(f"{f:.4g}" for f in v[:4])
            + (", ..." if len(v) > 4 else "") + " Hz)" for k, v in counts.items()))
    kinds: dict[str, list[int]] = {}
    for k, w in enumerate(fit.warnings):
        for msg in w:
            kinds.setdefault(msg.split(":")[0], []).append(k + 1)
    for kind, modes in kinds.items():
        lines.append(f"batlab fit: {kind} in mode(s) {', '.join(map(str, modes))} "
                     "(details per mode in --json)")
    for c in fit.close_pairs:
        lines.append(f"batlab fit: close pair: modes {c.i + 1} and {c.j + 1} "
                     f"({c.separation:.2%} apart, modal overlap {c.modal_overlap:.2f}, "
                     f"MAC {c.mac:.3f})")
    return lines


def run(args: argparse.Namespace) -> int:
    """Fit the modes of one FRF test file and print (or write) them.

    Parameters
    ----------
    args : argparse.Namespace
        The options ``add_arguments`` defines.

    Returns
    -------
    int
        Exit code: 0 (bad input raises ValueError or OSError; ``batlab.cli`` prints
        it in one line and exits 2).
    """
    from batlab import pipeline

    test = pipeline.admit(args, note_printer("fit"),
                          outputs={"out": "file", "plots": "dir"})["test"]
    print(f"batlab fit: {test.frf.shape[1]} x {test.frf.shape[2]} FRFs, "
          f"{test.freq_hz.size} lines; fitting ({args.method})", file=sys.stderr)
    fit = pipeline.fit_test_file(test, band_hz=args.band, method=args.method,
                                 max_order=args.max_order, known_mass_kg=args.mass_kg,
                                 refine=args.refine, min_snr=args.min_snr, name=args.test)
    print(f"batlab fit: {fit.freq_hz.size} modes"
          + ("" if fit.scaled else " (unscaled shapes: no driving point)"), file=sys.stderr)
    for line in explain(fit):
        print(line, file=sys.stderr)
    if args.out:
        pipeline.write_modes_file(args.out, fit)
        print(f"batlab fit: modes written to {args.out}", file=sys.stderr)
    if args.plots:
        for path in pipeline.plot_fit_files(fit, test, args.plots):
            print(f"batlab fit: plot {path}", file=sys.stderr)
    if args.json:
        print(json.dumps(summary(fit)))
    else:
        print(_table(fit))
    return 0
