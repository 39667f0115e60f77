"""Rig check on a reference bar: whether the measured modes, damping and scaling match it.

The bar's model (updating.model.bar: free-free Timoshenko, its accelerometer at the driving
point) is paired with the measured modes by MAC. Checks, each with its tolerance:

- frequencies: |f_measured / f_model - 1| <= freq_tol for every paired mode (a handbook E
  of a metal bar is good to ~1 %; larger errors: wrong mass or E, or a slipping sensor);
- damping: zeta <= max_damping (a metal bar on soft cords has well under 0.5 %; more means
  a clamp, a hand, a stiff cord, or a poor fit);
- amplitude scale: the measured mass-normalised shapes against the model's, per mode
  q_r = u_r . y_r / u_r . u_r; an error s in the product of the hammer and accelerometer
  sensitivities scales the FRFs by s and the shapes by sqrt(s) (shapes come from
  residues A = phi_j phi_k), so s = median(q)^2; |s - 1| <= scale_tol;
- mass line (when the fit measured it): the lower residual at the driving point against
  the bar's rigid-body flexibility 1/M + (x_d - x_c)^2 / I (ema.shapes.mass_line), within
  scale_tol;
- every model mode in the fitted band was found (MAC >= min_mac).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.correlate.measured import MeasuredModes
from updating.correlate.pairing import pair_modes
from updating.model.assembly import displacement_at
from updating.model.bar import Bar
from updating.model.mass_properties import mass_properties
from updating.model.modes import model_modes

FREQ_TOL = 0.015
MAX_DAMPING = 0.005
SCALE_TOL = 0.10


@dataclass(frozen=True)
class Check:
    """One check: its name, measured value, tolerance, pass/fail and a sentence."""

    name: str
    value: float | None
    tolerance: float
    ok: bool
    text: str


@dataclass(frozen=True)
class RigCheck:
    """Result of check_rig: paired modes and the checks."""

    model_hz: np.ndarray
    measured_hz: np.ndarray
    damping: np.ndarray
    scale: np.ndarray
    mac: np.ndarray
    missing_hz: np.ndarray
    checks: tuple[Check, ...]

    @property
    def ok(self) -> bool:
        """Return whether every check passed."""
        return all(c.ok for c in self.checks)

    def to_json_dict(self) -> dict:
        """Return the rig check as a JSON-able dict: ok, the paired modes and the checks."""
        return {
            "ok": self.ok,
            "modes": [{"model_hz": float(m), "measured_hz": float(f),
                       "error_pct": float(100 * (f / m - 1)), "damping_pct": float(100 * z),
                       "scale": float(q), "mac": float(c)}
                      for m, f, z, q, c in zip(self.model_hz, self.measured_hz, self.damping,
                                               self.scale, self.mac, strict=True)],
            "missing_model_hz": [float(f) for f in self.missing_hz],
            "checks": [{"name": c.name, "value": c.value, "tolerance": c.tolerance,
                        "ok": c.ok, "text": c.text} for c in self.checks],
        }


def check_rig(
    bar: Bar, measured: MeasuredModes, mass_line_1_per_kg: float | None = None,
    freq_tol: float = FREQ_TOL, max_damping: float = MAX_DAMPING, scale_tol: float = SCALE_TOL,
    min_mac: float = 0.8,
) -> RigCheck:
    """Compare a test of the bar with its model (module docstring)."""
    x = np.asarray(measured.x_m, dtype=float)
    if np.any(x < -1e-9) or np.any(x > bar.length_m + 1e-9):
        raise ValueError("a test point lies outside the bar (check the UFF node positions "
                         "and length in the bar file)")
    model = bar.model(stations_m=x, sensor_x_m=measured.sensor_x_m)
    n = measured.freq_hz.size + 4
    modes = model_modes(model, n + 2).elastic()
    u = displacement_at(model, modes.shapes, x)
    im, jm, macs = pair_modes(measured.shapes, u, min_mac=min_mac)
    order = np.argsort(measured.freq_hz[im])
    im, jm, macs = im[order], jm[order], macs[order]
    f_mod, f_meas = modes.freq_hz[jm], measured.freq_hz[im]
    y, um = measured.shapes[:, im], u[:, jm]
    q = np.abs(np.sum(um * y, axis=0) / np.sum(um * um, axis=0))
    zeta = np.asarray(measured.damping_ratio)[im]
    top = measured.freq_hz.max() if measured.freq_hz.size else 0.0
    missing = np.setdiff1d(np.flatnonzero(modes.freq_hz <= top * 1.001), jm)
    checks = []
    if im.size == 0:
        checks.append(Check("pairing", None, min_mac, False,
                            f"no measured mode matches a mode of the bar (MAC < {min_mac})"))
    else:
        err = np.abs(f_meas / f_mod - 1)
        worst = int(np.argmax(err))
        checks.append(Check(
            "frequencies", float(err.max()), freq_tol, bool(err.max() <= freq_tol),
            f"largest frequency error {100 * (f_meas[worst] / f_mod[worst] - 1):+.2f} % "
            f"(mode at {f_mod[worst]:.1f} Hz; tolerance {100 * freq_tol:.1f} %)"))
        checks.append(Check(
            "damping", float(zeta.max()), max_damping, bool(zeta.max() <= max_damping),
            f"largest damping ratio {100 * zeta.max():.3f} % (at most {100 * max_damping:.2f} "
            "% for a bar on soft cords)"))
        s = float(np.median(q) ** 2)
        checks.append(Check(
            "amplitude_scale", s, scale_tol, bool(abs(s - 1) <= scale_tol),
            f"measured FRFs are {s:.3f} x the bar's (hammer x accelerometer sensitivity "
            f"error; tolerance +-{100 * scale_tol:.0f} %)"))
    if mass_line_1_per_kg is not None and np.isfinite(mass_line_1_per_kg):
        mp = mass_properties(model, with_attachments=True)
        d = measured.sensor_x_m
        g = 1 / mp.mass_kg + (d - mp.cg_m) ** 2 / mp.i_cg_kg_m2
        r = float(mass_line_1_per_kg / g)
        checks.append(Check("mass_line", r, scale_tol, bool(abs(r - 1) <= scale_tol),
                            f"driving-point mass line {r:.3f} x the bar's rigid-body "
                            f"flexibility (tolerance +-{100 * scale_tol:.0f} %)"))
    checks.append(Check(
        "all_modes_found", float(missing.size), 0.0, missing.size == 0,
        "every bending mode of the bar in the band was found" if missing.size == 0 else
        "bar modes not found: " + ", ".join(f"{modes.freq_hz[j]:.0f} Hz" for j in missing)))
    return RigCheck(f_mod, f_meas, zeta, q, macs, modes.freq_hz[missing], tuple(checks))
