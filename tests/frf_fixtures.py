"""Physical FRF tests for the file tests: a free-free beam-like bat from a few modes."""

from __future__ import annotations

import numpy as np

from ema.io.frf_data import FrfTest
from rigs.modal_model import ModalModel

LENGTH_M = 0.84


def bat_modal_model(x_m: np.ndarray) -> ModalModel:
    """Two suspension (rigid-body) modes and three bending modes, mass-normalised-ish shapes."""
    x = np.asarray(x_m, dtype=float)
    u = x / LENGTH_M
    shapes = [np.ones_like(u), u - 0.5] + [np.cos((k + 1.5) * np.pi * u) for k in range(3)]
    return ModalModel(
        freq_hz=[1.8, 5.5, 152.0, 431.0, 805.0],
        damping_ratio=[0.05, 0.05, 0.012, 0.009, 0.007],
        shapes=np.stack(shapes, axis=1) * 1.1,
        x_m=x,
    )


def bat_test(
    n_points: int = 8,
    n_lines: int = 801,
    df_hz: float = 0.5,
    drive: bool = True,
    first_node: int = 1,
    coherence: bool = False,
    quantity: str = "accelerance",
) -> FrfTest:
    """Roving-hammer test: one accelerometer near the barrel end, impacts at every point.

    With ``drive`` the accelerometer sits on the last impact point (the driving point);
    without, it sits between points on a node of its own.
    """
    x = np.linspace(0.0254, LENGTH_M - 0.03, n_points)
    nodes = np.arange(first_node, first_node + n_points)
    x_acc = x[-1] if drive else x[-1] - 0.01
    model = bat_modal_model(np.append(x, x_acc))
    f = np.arange(n_lines) * df_hz
    if quantity == "receptance":
        h = model.receptance(f, [n_points], np.arange(n_points))
    elif quantity == "mobility":
        h = 2j * np.pi * f[:, None, None] * model.receptance(f, [n_points], np.arange(n_points))
    else:
        h = model.accelerance(f, [n_points], np.arange(n_points))
    acc_node = nodes[-1] if drive else first_node + n_points
    node_x = dict(zip(nodes.tolist(), x.tolist(), strict=True))
    node_x[int(acc_node)] = float(x_acc)
    coh = None
    if coherence:
        # coherence dips where the FRF is small (anti-resonances), as measured ones do
        mag = np.abs(h)
        coh = mag**2 / (mag**2 + 1e-3 * np.median(mag) ** 2)
    return FrfTest(
        freq_hz=f, frf=h, response_nodes=[acc_node], reference_nodes=nodes, node_x_m=node_x,
        quantity=quantity, coherence=coh, exp_window_tau_s=0.0625,
        meta={"estimator": "H1", "serial": "HX-1004"},
    )
