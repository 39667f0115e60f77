"""`batlab fit`: automatic experimental modal analysis of one FRF test file."""

from __future__ import annotations

import json
import sys

HELP = "fit natural frequencies, damping and mass-normalised mode shapes to a test's FRFs"
EXAMPLE = "batlab fit baseline.uff --json"


def add_arguments(p) -> None:
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
    p.add_argument("--mass-kg", type=float, default=None,
                   help="the bat's mass, kg, for the mass-line scaling check")
    p.add_argument("--json", action="store_true", help="print the modes as JSON on stdout")
    p.add_argument("--plot", metavar="DIR", default=None,
                   help="write stabilisation.png, synthesis.png and automac.png into DIR")
    p.add_argument("-o", "--out", metavar="MODES.uff", default=None,
                   help="write the real mass-normalised modes as UFF 55")


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
        })
    return rows


def _num(v: float) -> float | None:
    return None if v != v else float(v)  # NaN -> null


def summary(fit) -> dict:
    """The JSON document of a fit (see docs/ema.md)."""
    rb = fit.rigid_body
    return {
        "method": fit.method,
        "band_hz": list(fit.band_hz),
        "quantity": fit.quantity,
        "driving_point_node": int(fit.nodes[fit.driving_index]),
        "modes": _mode_rows(fit),
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
    if rb.mass_kg is not None:
        lines.append(f"rigid body from the scaling: mass {rb.mass_kg:.4f} kg, centre of mass "
                     f"{rb.x_cg_m:.4f} m, pitch inertia {rb.pitch_inertia_kg_m2:.5f} kg m^2")
    if rb.mass_upper_bound_kg is not None:
        lines.append(f"mass line at the driving point bounds the mass from below: "
                     f"M >= 1/a(x_d) = {rb.mass_upper_bound_kg:.4f} kg")
    return "\n".join(lines)


def run(args) -> int:
    from ema.fit import fit_test
    from ema.io.frf_io import read_test

    print(f"batlab fit: reading {args.test}", file=sys.stderr)
    test = read_test(args.test)
    print(f"batlab fit: {test.frf.shape[1]} x {test.frf.shape[2]} FRFs, "
          f"{test.freq_hz.size} lines; fitting ({args.method})", file=sys.stderr)
    fit = fit_test(test, band_hz=args.band, method=args.method, max_order=args.max_order,
                   known_mass_kg=args.mass_kg, refine=args.refine)
    print(f"batlab fit: {fit.freq_hz.size} modes", file=sys.stderr)
    if args.out:
        from ema.io.uff_modes import write_modes_uff

        write_modes_uff(args.out, fit.freq_hz, fit.damping_ratio, fit.real_shapes, fit.nodes,
                        fit.x_m)
        print(f"batlab fit: modes written to {args.out}", file=sys.stderr)
    if args.plot:
        from ema.plots import plot_fit

        sel = (test.freq_hz >= fit.band_hz[0]) & (test.freq_hz <= fit.band_hz[1])
        sel &= test.freq_hz > 0
        for path in plot_fit(fit, test.frf[sel], args.plot):
            print(f"batlab fit: plot {path}", file=sys.stderr)
    if args.json:
        print(json.dumps(summary(fit)))
    else:
        print(_table(fit))
    return 0
