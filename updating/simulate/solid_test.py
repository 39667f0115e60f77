"""3D-simulated roving-hammer tests: the FRFs of a bat's 3D solid (updating.solid).

They are made as updating.simulate.virtual_bat.simulate_test makes them for the 1D bat.

A hammer and accelerometer along the angle theta from the y axis (the radial grain plane of
planar grain) measure

    H = cos^2(theta) H_y + sin^2(theta) H_z,
    H_p(w) = sum_r -w^2 phi_r(x_s) phi_r(x_j) / (w_r^2 - w^2 + 2 i zeta_r w_r w),

over the two suspension modes (the solid's rigid body on two bungees 1 in from the ends, the
same in both planes, 3 % damping) and the plane's bending modes (mass-normalised transverse
displacement of the axis, interpolated at the points; damping zeta_1 (f / f_1)^0.3), then
relative and floor noise (rigs.virtual_test.add_noise). The suspension modes are those of the
rigid body on springs, [k sum [1, x_b][1, x_b]^T - w^2 R] v = 0 with R the solid's rigid-body
mass matrix about the knob end (updating.solid.modes.SolidModes.rigid, the accelerometer
included): above them they carry the solid's exact mass line.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ema.io.frf_data import FrfTest
from rigs.modal_model import ModalModel
from rigs.virtual_test import add_noise
from updating.model.units import IN_TO_M
from updating.simulate.virtual_bat import DEFAULT_FREQ_HZ, damping_ratios
from updating.solid.modes import SolidModes


def suspension_modes(
    rigid: tuple[float, float, float], bungee_x_m: tuple[float, ...], k_n_per_m: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Compute the modes of a rigid body (mass, x_cg, I_cg) on transverse springs.

    The springs ``k_n_per_m`` sit at ``bungee_x_m``.

    Returns
    -------
    freq_hz : ndarray
        (2,) frequencies, Hz.
    vectors : ndarray
        (2, 2) mass-normalised [translation, rotation] vectors.
    """
    mass, cg, i_cg = rigid
    R = np.array([[mass, mass * cg], [mass * cg, i_cg + mass * cg**2]])
    K = sum(k_n_per_m * np.outer([1.0, x], [1.0, x]) for x in bungee_x_m)
    lam, vec = scipy.linalg.eigh(K, R)
    return np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi), vec


def tap_test_frf(
    modes: SolidModes, points_m: np.ndarray, sensor_index: int, theta_deg: float,
    bungee_k_n_per_m: float = 150.0, freq_hz: np.ndarray = DEFAULT_FREQ_HZ,
    zeta1: float = 0.005, zeta_exponent: float = 0.3, rel_noise: float = 0.005,
    floor_noise: float = 1e-3, seed: int | None = None,
) -> FrfTest:
    """Simulate the roving-hammer test of the solid (module docstring): one FRF per point.

    The accelerometer is at ``points_m[sensor_index]`` (``modes`` solved with its mass there).
    """
    if modes.rigid is None:
        raise ValueError("the solid's modes carry no rigid-body properties")
    x = np.asarray(points_m, dtype=float)
    length = float(np.max(modes.axis_x_m))
    f_s, v = suspension_modes(modes.rigid, (IN_TO_M, length - IN_TO_M), bungee_k_n_per_m)
    rigid_shapes = v[0][None, :] + x[:, None] * v[1][None, :]
    th = np.radians(theta_deg)
    h = 0.0
    for plane, weight in (("y", np.cos(th) ** 2), ("z", np.sin(th) ** 2)):
        bend = np.flatnonzero(modes.kind == f"bend_{plane}")
        f_b = modes.freq_hz[bend]
        w = np.column_stack([np.interp(x, modes.axis_x_m, modes.axis_w[:, j]) for j in bend])
        model = ModalModel(np.r_[f_s, f_b],
                           np.r_[np.full(2, 0.03), damping_ratios(f_b, zeta1, zeta_exponent)],
                           np.hstack([rigid_shapes, w]), x)
        h = h + weight * model.accelerance(freq_hz, np.array([sensor_index]), np.arange(x.size))
    h = add_noise(h, rel_noise, floor_noise, seed)
    nodes = np.arange(1, x.size + 1)
    return FrfTest(np.asarray(freq_hz, dtype=float), h, nodes[[sensor_index]], nodes,
                   {int(n): float(p) for n, p in zip(nodes, x, strict=True)},
                   meta={"source": "batlab 3D solid (updating.solid)", "seed": seed})
