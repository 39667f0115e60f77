"""The acquisition behind `batlab acquire`.

The acquisition behind `batlab acquire`: the box's driver, capture settings and the
roving-hammer session (``rigs``), the session's files beside its raw stream, and the FRF file
written at the end (``ema.io``).

A session's completed points' FRF estimates go to ``RAW.points.npz`` as each point completes,
so a killed session keeps them (`batlab acquire --resume`); the sidecar ``RAW.json`` and the
FRF file are written atomically (``ema.io.atomic_write``: temporary name, then rename).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ema.io.atomic_write import atomic_write
from ema.io.frf_data import FrfTest
from rigs.capture import CaptureSettings
from rigs.driver import ReplaySource, SerialDevice, open_port
from rigs.frf_estimate import FrfEstimate
from rigs.protocol import device_info_from_dict
from rigs.session import DEFAULT_POINTS_IN, SessionInterrupted, combine, run_session

__all__ = [
    "DEFAULT_POINTS_IN", "CaptureSettings", "ReplaySource", "SerialDevice",
    "SessionInterrupted", "combine", "device_info_from_dict", "load_points", "open_port",
    "run_session", "save_points", "write_json_atomic", "write_session_test",
]


def write_json_atomic(path, obj: dict) -> None:
    """``obj`` as indented JSON at ``path`` (temporary name, then rename)."""
    atomic_write(path, lambda tmp: Path(tmp).write_text(json.dumps(obj, indent=1)))


def write_session_test(out, result, points: list[int], driving: int,
                       node_x_m: dict[int, float], exp_window_tau_s: float | None, raw,
                       hits: int) -> FrfTest:
    """Combine a session's H1 FRFs into an ``FrfTest``.

    The session's H1 FRFs as an ``FrfTest`` (response node ``driving``, impact nodes the
    session's ``points``, positions ``node_x_m`` by point number), written to ``out`` (UFF,
    CSV or NPZ by extension; atomic).
    """
    from ema.io.frf_io import write_test

    test = FrfTest(result.freq_hz, result.h1, [driving], result.points,
                   {n: node_x_m[n] for n in sorted(set(points) | {driving})},
                   coherence=result.coherence, exp_window_tau_s=exp_window_tau_s,
                   meta={"source": "batlab acquire", "raw_stream": str(raw),
                         "device": result.info.name, "hits_per_point": hits})
    write_test(out, test)
    return test


def save_points(path, estimates: dict[int, FrfEstimate]) -> None:
    """Save every completed point's FRF estimate in one NPZ.

    Every completed point's FRF estimate in one NPZ (atomic: temporary name, rename), so a
    killed session keeps what it measured: ``point_N_{h1,h2,coherence}``, ``freq_hz``,
    ``n_averages`` and ``points`` (in completion order).
    """
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
    """Load the completed points saved by :func:`save_points` (empty when there is no file)."""
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
