"""Measured modes as the updating stage consumes them, and where their points sit on a mesh.

The modes may come from any fitter.

``MeasuredModes`` is the one measured mode-set type of ``updating``: ``from_fit`` converts an
``ema`` modal fit (``ema.modal_fit.ModalFit``) into it, ``sampled_modes`` turns a model's modes at
chosen DOFs into a noise-free "test" (the paper's case), ``with_noise`` perturbs one.
The model side is ``updating.model.modes.Modes`` (the FE eigen-solution).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from updating.model.assembly import BatModel
from updating.model.modes import Modes


@dataclass(frozen=True)
class MeasuredModes:
    """Identified elastic modes of one test.

    Attributes
    ----------
        freq_hz: (m,) natural frequencies, Hz, ascending.
        shapes: (n_points, m) real mass-normalised shapes at the impact points, 1/sqrt(kg).
        x_m: (n_points,) positions of the points from the knob end, m.
        damping_ratio: (m,) modal damping ratios.
        sensor_x_m: position of the accelerometer (the driving point), m (NaN: none, as for
            modes sampled from a model).
        freq_std_hz: (m,) standard uncertainty of the frequencies, or None.
        mass_line: (n_points,) the driving point's row of the rigid-body flexibility at the
            points, 1/kg (the mass line, ``ema.shapes.mass_line``: 1/M + (x - x_c)(x_d -
            x_c)/I of the bat with its accelerometer), or None when the test did not give it.
        band_top_hz: the top of the band the modes were fitted in, Hz, or None (unknown): a
            mode near it may have its other bending plane's member above it.
        members: (m,) how many fitted modes each mode stands for: 2 where a resolved pair of
            bending planes was merged into it (``planes.merge_plane_pairs``), 1 for a mode
            seen once; None when not recorded.
        plane_pair_hz: (m, 2) the frequencies of the two fitted members (lower, upper) of
            each merged pair, NaN for a mode seen once; None when not recorded. The
            re-test's change of their split reads a flat (``updating.inspect.plane_split``).
        plane_pair_std_hz: (m, 2) their standard uncertainties (NaN where the fit gave
            none), or None.
        shape_noise_rel: (m,) relative standard deviation of a shape entry per mode, measured
            from the test's coherence and averages (``ema.shapes.noise``), or None (no
            coherence: the inspection estimates it from its fits' residuals).
    """

    freq_hz: np.ndarray
    shapes: np.ndarray
    x_m: np.ndarray
    damping_ratio: np.ndarray
    sensor_x_m: float
    freq_std_hz: np.ndarray | None = None
    mass_line: np.ndarray | None = None
    band_top_hz: float | None = None
    members: np.ndarray | None = None
    plane_pair_hz: np.ndarray | None = None
    plane_pair_std_hz: np.ndarray | None = None
    shape_noise_rel: np.ndarray | None = None

    @property
    def omega2(self) -> np.ndarray:
        """(2 pi f)^2, rad^2/s^2: the eigenvalues the test measured."""
        return (2 * np.pi * np.asarray(self.freq_hz)) ** 2

    def select(self, idx) -> MeasuredModes:
        """Return a subset of the modes."""
        idx = np.asarray(idx)
        std = None if self.freq_std_hz is None else self.freq_std_hz[idx]
        members = None if self.members is None else self.members[idx]
        pair = None if self.plane_pair_hz is None else self.plane_pair_hz[idx]
        pair_std = None if self.plane_pair_std_hz is None else self.plane_pair_std_hz[idx]
        noise = None if self.shape_noise_rel is None else self.shape_noise_rel[idx]
        return MeasuredModes(self.freq_hz[idx], self.shapes[:, idx], self.x_m,
                             self.damping_ratio[idx], self.sensor_x_m, std, self.mass_line,
                             self.band_top_hz, members, pair, pair_std, noise)


def from_fit(fit, sensor_x_m: float, min_hz: float = 20.0) -> MeasuredModes:
    """Convert an ``ema`` modal fit into its elastic modes above ``min_hz``.

    The fit is duck-typed: freq_hz, damping_ratio, real_shapes, x_m, optional freq_std_hz and
    the mass line; ``sensor_x_m`` is the driving point's position.
    """
    keep = np.flatnonzero(np.asarray(fit.freq_hz) >= min_hz)
    std = getattr(fit, "freq_std_hz", None)
    band = getattr(fit, "band_hz", None)
    noise = getattr(fit, "shape_noise_rel", None)
    return MeasuredModes(
        np.asarray(fit.freq_hz)[keep], np.asarray(fit.real_shapes)[:, keep],
        np.asarray(fit.x_m), np.asarray(fit.damping_ratio)[keep], float(sensor_x_m),
        None if std is None else np.asarray(std)[keep], driving_mass_line(fit),
        None if band is None else float(band[1]), np.ones(keep.size, dtype=int),
        shape_noise_rel=None if noise is None else np.asarray(noise, dtype=float)[keep])


def driving_mass_line(fit) -> np.ndarray | None:
    """Return the driving point's row of the rigid-body flexibility at the shape nodes (1/kg).

    From the suspension modes when the fit has two (sum_s phi_s(x) phi_s(x_d)), else the lower
    residual's row (``ema.modal_fit.ModalFit.mass_line``); None without a driving point or when
    neither is there.
    """
    d = getattr(fit, "driving_index", None)
    frf = getattr(fit, "driving_frf", None)
    if d is None or frf is None:
        return None
    n = np.asarray(fit.x_m).size
    susp = np.asarray(getattr(fit, "suspension_shapes", np.zeros((n, 0))), dtype=float)
    if susp.ndim == 2 and susp.shape == (n, susp.shape[1]) and susp.shape[1] >= 2:
        return susp @ susp[d]
    ml = getattr(fit, "mass_line", None)
    if ml is None:
        return None
    ml = np.asarray(ml, dtype=float)
    row = ml[frf[0], :] if ml.shape[1] == n else ml[:, frf[1]]
    if row.size != n or not np.any(row):
        return None
    return row.copy()


def sampled_modes(modes: Modes, dofs: np.ndarray, node_x_m: np.ndarray) -> MeasuredModes:
    """Read a model's modes at translational ``dofs`` (2 x node index) as a noise-free test.

    Shapes ``modes.shapes[dofs]`` at x = ``node_x_m[dofs // 2]``, no damping, no sensor.
    """
    dofs = np.asarray(dofs, dtype=int)
    f = np.asarray(modes.freq_hz, dtype=float)
    return MeasuredModes(f, np.asarray(modes.shapes)[dofs], np.asarray(node_x_m)[dofs // 2],
                         np.zeros(f.size), float("nan"))


def with_noise(test: MeasuredModes, shape_sigma: float, freq_sigma: float,
               rng: np.random.Generator) -> MeasuredModes:
    """Test modes with Gaussian noise: shapes + N(0, (shape_sigma rms_r)^2), f (1 + N(0, s^2))."""
    rms = np.sqrt(np.mean(test.shapes**2, axis=0))
    shapes = test.shapes + rng.standard_normal(test.shapes.shape) * shape_sigma * rms
    freq = np.asarray(test.freq_hz) * (1 + freq_sigma * rng.standard_normal(len(test.freq_hz)))
    return replace(test, freq_hz=freq, shapes=shapes)


def dofs_at(model: BatModel, x_m, tol_m: float = 1e-6) -> np.ndarray:
    """Return the translational DOFs of the nodes at x_m (each must be a mesh node within tol_m)."""
    x = np.atleast_1d(np.asarray(x_m, dtype=float))
    node = np.abs(model.node_x_m[None, :] - x[:, None]).argmin(axis=1)
    bad = np.flatnonzero(np.abs(model.node_x_m[node] - x) > tol_m)
    if bad.size:
        raise ValueError(f"measured point x = {x[bad[0]]:.4f} m is not a mesh node (build the "
                         "model with stations_m at the measured points)")
    return 2 * node
