"""A roving-hammer session's files beside its raw stream: the completed points' FRF
estimates (``RAW.points.npz``), saved as each point completes so a killed session keeps them
(`batlab acquire --resume`). Written atomically (``ema.io.atomic_write``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ema.io.atomic_write import atomic_write
from rigs.frf_estimate import FrfEstimate


def save_points(path, estimates: dict[int, FrfEstimate]) -> None:
    """Every completed point's FRF estimate in one NPZ (atomic: temporary name, rename), so a
    killed session keeps what it measured: ``point_N_{h1,h2,coherence}``, ``freq_hz``,
    ``n_averages`` and ``points`` (in completion order)."""
    order = list(estimates)
    arrays = {"points": np.asarray(order, dtype=int),
              "n_averages": np.asarray([estimates[n].n_averages for n in order], dtype=int)}
    if order:
        arrays["freq_hz"] = estimates[order[0]].freq_hz
    for n in order:
        for name in ("h1", "h2", "coherence"):
            arrays[f"point_{n}_{name}"] = getattr(estimates[n], name)

    def write(tmp):
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)

    atomic_write(path, write)


def load_points(path, exp_window_tau_s: float | None) -> dict[int, FrfEstimate]:
    """The completed points saved by :func:`save_points` (empty when there is no file)."""
    if not Path(path).exists():
        return {}
    try:
        with np.load(path) as z:
            out = {}
            for n, navg in zip(z["points"].tolist(), z["n_averages"].tolist(), strict=True):
                out[int(n)] = FrfEstimate(z["freq_hz"], z[f"point_{n}_h1"], z[f"point_{n}_h2"],
                                          z[f"point_{n}_coherence"], int(navg), exp_window_tau_s)
            return out
    except (OSError, KeyError, ValueError) as exc:
        raise ValueError(f"{path}: unreadable saved points ({exc})") from None
