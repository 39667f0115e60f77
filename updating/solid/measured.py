"""The solid's bending modes as a tap test sees them (3D-simulated test data).

A hammer and accelerometer along the angle theta from the y axis (the radial grain plane of
planar grain) see the y-plane modes with shapes cos(theta) w_y and the z-plane modes with
sin(theta) w_z, w the mass-normalised transverse displacement of the axis at the test points
(linear interpolation between the axis nodes of the quadratic mesh, 0.5 element apart).
Frequencies and shape entries get relative Gaussian noise as in
updating.simulate.virtual_bat.simulate_modes. The FRFs of such a test:
updating.simulate.solid_test.
"""

from __future__ import annotations

import numpy as np

from updating.correlate.measured import MeasuredModes
from updating.solid.modes import SolidModes


def tap_test_modes(
    modes: SolidModes, points_m: np.ndarray, sensor_x_m: float, theta_deg: float,
    n_per_plane: int = 6, freq_noise: float = 5e-4, shape_noise: float = 0.005,
    seed: int | None = None, zeta: float = 0.005,
) -> MeasuredModes:
    """MeasuredModes of both bending planes' first ``n_per_plane`` modes, ascending."""
    th = np.radians(theta_deg)
    f, y = [], []
    for plane, scale in (("y", np.cos(th)), ("z", np.sin(th))):
        sel = np.flatnonzero(modes.kind == f"bend_{plane}")[:n_per_plane]
        for j in sel:
            f.append(modes.freq_hz[j])
            y.append(scale * np.interp(points_m, modes.axis_x_m, modes.axis_w[:, j]))
    f, y = np.array(f), np.array(y).T
    keep = np.flatnonzero(np.sqrt(np.mean(y**2, axis=0)) > 1e-9)  # theta = 0 or 90 deg
    f, y = f[keep], y[:, keep]
    order = np.argsort(f)
    f, y = f[order], y[:, order]
    rng = np.random.default_rng(seed)
    f = f * (1 + freq_noise * rng.standard_normal(f.size))
    y = y + shape_noise * np.sqrt(np.mean(y**2, axis=0)) * rng.standard_normal(y.shape)
    return MeasuredModes(f, y, np.asarray(points_m, dtype=float), np.full(f.size, zeta),
                         float(sensor_x_m), freq_noise * f)

