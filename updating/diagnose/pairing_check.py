"""Checks that keep `diagnose` from naming causes out of a bad pairing.

A cause is named from frequency errors of *paired* modes; if the pairing is wrong the errors
are meaningless and so are the causes. Checked:

- **unreliable shapes**: fewer than ``MIN_POINTS`` test points, or the MAC pairing with the
  nominal model pairs fewer than half the measured modes or with a median MAC below
  ``MIN_MEDIAN_MAC``: the shapes cannot choose the partner, so measured mode i is paired
  with the model's elastic mode i (frequency order) and this is said;
- **low-MAC pairs**: a pair of the calibrated model with MAC below ``MIN_PAIR_MAC``;
- **skipped modes**: the paired model modes, in ascending measured frequency, are not
  0, 1, 2, ... (a model mode left out, or every pair shifted by one);
- **parameters at their bounds**: a fitted parameter within 0.1 % of the bound range of a
  bound it cannot physically sit at (the lower bounds of the sensor mass and the bungee
  stiffness, 0, are physical and not flagged).
Any of the last three (the second only when the pairing is by MAC) makes the pairing
untrustworthy: the causes are then not named (``refuse_causes``).
"""

from __future__ import annotations

import numpy as np

from updating.diagnose.calibration import DiagnosisFit
from updating.diagnose.model import BOUNDS

MIN_POINTS = 3
MIN_MEDIAN_MAC = 0.5
MIN_PAIR_MAC = 0.8
PHYSICAL_LOWER = ("sensor_g", "bungee_kn_per_m")
REFUSING = ("low MAC", "skipped", "bound")


def checked_pairing(
    freq_hz: np.ndarray, n_points: int, meas_idx: np.ndarray, model_idx: np.ndarray,
    macs: np.ndarray, n_model: int,
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Pair by MAC, or in frequency order when the shapes are unreliable (module docstring).

    Returns
    -------
    measured_index, model_index : ndarray
        The pairs.
    warnings : list of str
        What made the pairing doubtful.
    """
    m = int(np.asarray(freq_hz).size)
    why = None
    if n_points < MIN_POINTS:
        why = f"{n_points} test point(s) (MAC needs at least {MIN_POINTS})"
    elif meas_idx.size < 0.5 * m:
        why = f"MAC paired only {meas_idx.size} of {m} measured modes"
    elif macs.size and float(np.median(macs)) < MIN_MEDIAN_MAC:
        why = f"median pair MAC {float(np.median(macs)):.2f} < {MIN_MEDIAN_MAC}"
    if why is None:
        return meas_idx, model_idx, []
    k = min(m, n_model)
    order = np.argsort(freq_hz)[:k]
    return order, np.arange(k), [f"shapes unreliable ({why}): modes paired in frequency order"]


def pairing_warnings(fit: DiagnosisFit, model_index: np.ndarray, by_mac: bool) -> list[str]:
    """Low-MAC pairs (when paired by MAC), skipped model modes, parameters at their bounds."""
    out = []
    if by_mac:
        low = np.flatnonzero(fit.mac < MIN_PAIR_MAC)
        if low.size:
            out.append("low MAC pairs: " + ", ".join(
                f"measured mode {k + 1} / model mode {int(model_index[k]) + 1} MAC "
                f"{fit.mac[k]:.2f}" for k in low) + f" (< {MIN_PAIR_MAC})")
    idx = np.asarray(model_index)
    # the two members of a split pair (both bending planes seen) share one model mode
    distinct = idx[np.r_[True, idx[1:] != idx[:-1]]] if idx.size else idx
    if idx.size and not np.array_equal(distinct, np.arange(distinct.size)):
        missing = sorted(set(range(int(idx.max()) + 1)) - set(idx.tolist()))
        out.append("pairing skipped model mode(s) " + ", ".join(str(k + 1) for k in missing)
                   + f" (paired model modes {', '.join(str(int(k) + 1) for k in idx)})")
    for name, x in zip(fit.names, fit.x, strict=True):
        lo, hi = BOUNDS[name]
        tol = 1e-3 * (hi - lo)
        at_hi = x >= hi - tol
        at_lo = x <= lo + tol and name not in PHYSICAL_LOWER
        if at_hi or at_lo:
            value = float(np.exp(x)) if name.startswith("ln_") else float(x)
            out.append(f"parameter {name.removeprefix('ln_')} = {value:.4g} is at its "
                       f"{'upper' if at_hi else 'lower'} bound")
    return out


def refuse_causes(warnings: list[str]) -> bool:
    """Return whether a warning makes the pairing untrustworthy (module docstring)."""
    return any(key in w for w in warnings for key in REFUSING)
