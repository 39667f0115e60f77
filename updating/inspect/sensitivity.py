"""The change predictor's derivatives from modal sensitivities, one eigen-solution a Jacobian.

A finite-difference Jacobian of the change fit solves the eigen-problem once more for every
parameter. Here each parameter's step changes only the matrices, dK = (K(x + h e_i) - K(x)) / h
and dM likewise (exact for the parameters K and M are linear in: moisture, temperature,
end grain, the accelerometer's and a substance's mass; the secant of the finite difference
for the positions and a core's geometry), formed from the terms the step changes
(``ChangePredictor.matrix_steps``); the modes' derivatives follow from every mode of
the unchanged state (``updating.model.sensitivity``):

    d ln f_r = d lambda_r / (2 lambda_r)
    d psi_jr = d phi_jr s_r + phi_jr d s_r,   s_r = sqrt(a_r / b_r)

with s_r the accelerometer's driving-point factor (``model.driving_point_scale``),
a_r = v^T phi_r (v the accelerometer's point vector, which a shift moves) and
b_r = phi_r at the driving point: d s_r = s_r / 2 (d a_r / a_r - d b_r / b_r).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.inspect.model import ChangeParams, ChangePredictor
from updating.model.sensitivity import mode_derivatives


@dataclass(frozen=True)
class PredictedChange:
    """The predictor's output at one state and its derivatives along k steps.

    Attributes
    ----------
    freq_hz : numpy.ndarray
        (n_solve,) frequencies, Hz.
    shapes : numpy.ndarray
        (n_points, n_solve) shapes as the tests see them (``ChangePredictor.observe``).
    d_lnf : numpy.ndarray
        (n_solve, k) d ln f per unit of each step's parameter.
    d_shapes : numpy.ndarray
        (n_points, n_solve, k) d shapes per unit of each step's parameter.
    """

    freq_hz: np.ndarray
    shapes: np.ndarray
    d_lnf: np.ndarray
    d_shapes: np.ndarray


def predicted_change(predict: ChangePredictor, params: ChangeParams,
                     steps: list[tuple[ChangeParams, float]]) -> PredictedChange:
    """Predict the modes at ``params`` and differentiate them along ``steps``.

    Parameters
    ----------
    predict : ChangePredictor
        The bat's change predictor.
    params : ChangeParams
        The state differentiated at.
    steps : list of (ChangeParams, float)
        For each parameter, the state one step h along it and h (in the parameter's unit).

    Returns
    -------
    PredictedChange
        Frequencies and observed shapes, and their derivatives (module docstring); kept
        by the predictor for the same state and steps (``ChangePredictor.derived``).
    """
    return predict.derived(("change", params, tuple(steps)),
                           lambda: _predicted_change(predict, params, steps))


def _predicted_change(predict: ChangePredictor, params: ChangeParams,
                      steps: list[tuple[ChangeParams, float]]) -> PredictedChange:
    """``predicted_change`` computed."""
    base, modes = predict.state(params)
    m = predict.n_solve
    dK, dM, dv = predict.matrix_steps(params, base, steps)
    v0 = base.sensor_vector()
    touched = np.flatnonzero((v0 != 0) | np.any(dv != 0, axis=0))
    rows = np.concatenate([base.point_rows, touched])
    deriv = mode_derivatives(modes, dK, dM, m, rows)
    lam, phi = modes.lam[:m], modes.vectors[:, :m]
    n_pts = base.point_rows.size
    at_pts, d_pts = phi[base.point_rows], deriv.d_shapes[:n_pts]
    a = v0[touched] @ phi[touched]
    da = np.einsum("i,irk->rk", v0[touched], deriv.d_shapes[n_pts:]) + \
        (dv[:, touched] @ phi[touched]).T
    b, db = at_pts[predict.drive], d_pts[predict.drive]
    ratio = a / np.where(b != 0, b, np.inf)
    s = np.sqrt(np.clip(ratio, 1e-6, None))
    live = (ratio > 1e-6)[:, None]
    ds = np.where(live, 0.5 * s[:, None] * (da / np.where(a != 0, a, np.inf)[:, None]
                                            - db / np.where(b != 0, b, np.inf)[:, None]), 0.0)
    shapes = at_pts * s
    d_shapes = d_pts * s[None, :, None] + at_pts[:, :, None] * ds[None, :, :]
    freq = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
    d_lnf = deriv.d_lambda / (2 * np.where(lam > 0, lam, np.inf))[:, None]
    return PredictedChange(freq, shapes, d_lnf, d_shapes)
