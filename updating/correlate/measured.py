"""Measured modes as the updating stage consumes them (from any fitter)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class MeasuredModes:
    """Identified elastic modes of one test.

    Attributes:
        freq_hz: (m,) natural frequencies, Hz, ascending.
        shapes: (n_points, m) real mass-normalised shapes at the impact points, 1/sqrt(kg).
        x_m: (n_points,) positions of the points from the knob end, m.
        damping_ratio: (m,) modal damping ratios.
        sensor_x_m: position of the accelerometer (the driving point), m.
        freq_std_hz: (m,) standard uncertainty of the frequencies, or None.
    """

    freq_hz: np.ndarray
    shapes: np.ndarray
    x_m: np.ndarray
    damping_ratio: np.ndarray
    sensor_x_m: float
    freq_std_hz: np.ndarray | None = None

    def select(self, idx) -> MeasuredModes:
        """A subset of the modes."""
        idx = np.asarray(idx)
        std = None if self.freq_std_hz is None else self.freq_std_hz[idx]
        return MeasuredModes(self.freq_hz[idx], self.shapes[:, idx], self.x_m,
                             self.damping_ratio[idx], self.sensor_x_m, std)


def from_fit(fit, sensor_x_m: float, min_hz: float = 20.0) -> MeasuredModes:
    """Elastic modes (above ``min_hz``) of an ``ema`` modal fit (duck-typed: freq_hz,
    damping_ratio, real_shapes, x_m, optional freq_std_hz); ``sensor_x_m`` is the driving
    point's position."""
    keep = np.flatnonzero(np.asarray(fit.freq_hz) >= min_hz)
    std = getattr(fit, "freq_std_hz", None)
    return MeasuredModes(
        np.asarray(fit.freq_hz)[keep], np.asarray(fit.real_shapes)[:, keep],
        np.asarray(fit.x_m), np.asarray(fit.damping_ratio)[keep], float(sensor_x_m),
        None if std is None else np.asarray(std)[keep])
