"""The physical model of what can change between a baseline test and a re-test.

Relative to the bat's calibrated reference (``BatReference``):

- moisture: uniform factors on the wood's stiffness (E and G together) and density,
  ``K = s_E K_wood + K_bungees``, ``M = s_rho M_wood + M_sensor``;
- the accelerometer re-mounted ``sensor_shift_m`` from where it was (same mass);
- optionally an axial core (``Core``: depth, diameter, fill density ratio, fill modulus,
  plug), built exactly into the section properties (Cowper shear coefficient included).

``make_predictor`` returns a function of these parameters giving the paired elastic modes'
frequencies and mass-normalised shapes at the test points. Wood matrices are cached per core
so that changes of moisture or sensor position cost one eigen-solution only.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from updating.model.assembly import BatModel, assemble, attachment_matrices, point_vector
from updating.model.modes import solve_modes
from updating.model.profile import Profile
from updating.model.reference import BatReference
from updating.model.sections import Core


@dataclass(frozen=True)
class ChangeParams:
    """One state of the bat relative to its reference (see module docstring)."""

    stiffness_scale: float = 1.0
    density_scale: float = 1.0
    sensor_shift_m: float = 0.0
    core: Core | None = None


@dataclass(frozen=True)
class WoodSystem:
    """The bat without its accelerometer: model, K_wood (+ bungees), M_wood, shape rows of
    the test points."""

    model: BatModel
    K: np.ndarray
    M: np.ndarray
    K_bungees: np.ndarray
    point_rows: np.ndarray


def wood_system(
    profile: Profile, reference: BatReference, points_m: np.ndarray, core: Core | None,
) -> WoodSystem:
    """Model of the bat (wood only) with nodes at the test points, and its bungees."""
    model = replace(reference, sensor_mass_kg=0.0).build(profile, points_m, core=core)
    K, M = assemble(model, with_attachments=False)
    Kb, _ = attachment_matrices(model)
    idx = np.searchsorted(model.node_x_m, points_m - 1e-9)
    if np.any(np.abs(model.node_x_m[np.minimum(idx, model.n_nodes - 1)] - points_m) > 1e-9):
        raise ValueError("test points must be nodes of the model")
    return WoodSystem(model, K, M, Kb, 2 * idx)


def make_predictor(
    profile: Profile, reference: BatReference, points_m: np.ndarray, sensor_x_m: float,
    n_solve: int,
) -> Callable[[ChangeParams], tuple[np.ndarray, np.ndarray]]:
    """f(params) -> (freq_hz (n_solve,), shapes at the points (n_points, n_solve)).

    All of the lowest ``n_solve`` modes are returned (suspension modes included); the caller
    selects the elastic ones by index. ``sensor_x_m`` is the accelerometer's position before
    any shift.
    """
    points_m = np.asarray(points_m, dtype=float)
    cache: dict[Core | None, WoodSystem] = {}

    def system(core: Core | None) -> WoodSystem:
        if core not in cache:
            if len(cache) > 32:
                cache.clear()
            cache[core] = wood_system(profile, reference, points_m, core)
        return cache[core]

    drive = int(np.argmin(np.abs(points_m - sensor_x_m)))

    def predict(p: ChangeParams) -> tuple[np.ndarray, np.ndarray]:
        ws = system(p.core)
        M = p.density_scale * ws.M
        x = float(np.clip(sensor_x_m + p.sensor_shift_m, 0.0, profile.length_m))
        dofs, n = point_vector(ws.model, x)
        if reference.sensor_mass_kg:
            M[np.ix_(dofs, dofs)] += reference.sensor_mass_kg * np.outer(n, n)
        modes = solve_modes(p.stiffness_scale * ws.K + ws.K_bungees, M, None, n_solve)
        shapes = modes.shapes[ws.point_rows]
        return modes.freq_hz, shapes * driving_point_scale(n @ modes.shapes[dofs],
                                                           shapes[drive])

    return predict


def driving_point_scale(at_sensor: np.ndarray, at_drive: np.ndarray) -> np.ndarray:
    """Per-mode factor sqrt(phi(x_s) / phi(x_d)) that a roving-hammer test puts on the
    mass-normalised shapes when its accelerometer sits at x_s, off the driving point x_d.

    The fitter scales through the driving-point FRF, H(x_s, x_d), with modal constant
    phi(x_s) phi(x_d), taking it for phi(x_d)^2 (``ema.shapes.scaling``): its shape at point j,
    phi(x_s) phi(x_j) / sqrt(phi(x_s) phi(x_d)), is phi(x_j) times this factor. A sensor
    re-mounted 0.1 in away near the barrel end changes it by a few % at the higher modes.
    Ratios that are not positive (the sensor across a node) are clipped.
    """
    ratio = np.asarray(at_sensor, dtype=float) / np.where(at_drive != 0, at_drive, np.inf)
    return np.sqrt(np.clip(ratio, 1e-6, None))


def baseline_sensor_offset(
    predict: Callable[[ChangeParams], tuple[np.ndarray, np.ndarray]], freq_hz: np.ndarray,
    shapes: np.ndarray, max_offset_m: float = 0.25 * 0.0254, min_mac: float = 0.8,
) -> float:
    """Where the accelerometer sat at the baseline test, relative to its labelled point, m.

    The baseline's mass-normalised shapes carry the driving-point factor of the sensor's true
    position (``driving_point_scale``); the offset minimising sum ||(psi - phi(offset)) /
    rms(psi)||^2 over the paired elastic modes (reference model ``predict``, sensor mass
    moved with it) is returned (bounded scalar search within +-``max_offset_m``). The change
    fit then models a re-mounted sensor exactly instead of to first order.
    """
    from scipy.optimize import minimize_scalar

    from updating.correlate.pairing import align_signs, pair_modes

    f0, phi0 = predict(ChangeParams())
    elastic = np.flatnonzero(f0 >= 20.0)
    jb, jm, _ = pair_modes(shapes, phi0[:, elastic], freq_a_hz=freq_hz, freq_b_hz=f0[elastic],
                           min_mac=min_mac, max_rel_df=0.3)
    if jb.size == 0:
        return 0.0
    psi = shapes[:, jb]
    rms = np.sqrt(np.mean(psi**2, axis=0))

    def cost(offset_m: float) -> float:
        _, phi = predict(ChangeParams(sensor_shift_m=offset_m))
        return float(np.sum(((psi - align_signs(psi, phi[:, elastic[jm]])) / rms) ** 2))

    res = minimize_scalar(cost, bounds=(-max_offset_m, max_offset_m), method="bounded",
                          options={"xatol": 1e-5})
    return float(res.x)
