"""Modal model of a test object at its test points, as the virtual rig uses it.

With real, mass-normalised modes phi (1/sqrt(kg)) and viscous modal damping, the
receptance between points j and k is

    H_jk(w) = sum_r phi_jr phi_kr / (w_r^2 - w^2 + 2 i zeta_r w_r w)      [m/N]

and accelerance is -w^2 times receptance [(m/s^2)/N] (Ewins, Modal Testing, ch. 2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ModalModel:
    """Modes of a structure sampled at its test points.

    Attributes
    ----------
    freq_hz : np.ndarray
        (m,) undamped natural frequencies, Hz (rigid-body/suspension modes included).
    damping_ratio : np.ndarray
        (m,) viscous modal damping ratios.
    shapes : np.ndarray
        (n_points, m) real mass-normalised mode shapes at the points, 1/sqrt(kg).
    x_m : np.ndarray
        (n_points,) positions of the points along the bat axis from the knob end, m.
    """

    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    x_m: np.ndarray

    def __post_init__(self) -> None:
        f = np.atleast_1d(np.asarray(self.freq_hz, dtype=float))
        z = np.broadcast_to(np.asarray(self.damping_ratio, dtype=float), f.shape).copy()
        s = np.asarray(self.shapes, dtype=float).reshape(-1, f.size)
        x = np.atleast_1d(np.asarray(self.x_m, dtype=float))
        if x.size != s.shape[0]:  # NaN positions are allowed (off-grid sensors)
            raise ValueError("one position per shape row is required")
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "damping_ratio", z)
        object.__setattr__(self, "shapes", s)
        object.__setattr__(self, "x_m", x)

    def _modal_factors(self, freq_hz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(w^2 (F, 1), den (F, m)) with den = w_r^2 - w^2 + 2 i zeta_r w_r w."""
        w = 2 * np.pi * np.asarray(freq_hz, dtype=float)[:, None]
        wr = 2 * np.pi * self.freq_hz[None, :]
        return w**2, wr**2 - w**2 + 2j * self.damping_ratio[None, :] * wr * w

    def _sum(self, factors: np.ndarray, resp, ref) -> np.ndarray:
        a = self.shapes[np.asarray(resp)]  # (n_resp, m)
        b = self.shapes[np.asarray(ref)]  # (n_ref, m)
        return np.einsum("im,jm,fm->fij", a, b, factors)

    def receptance(self, freq_hz: np.ndarray, resp: np.ndarray, ref: np.ndarray) -> np.ndarray:
        """Receptance H[f, i, j] (m/N) between points ``resp[i]`` and ``ref[j]`` (indices).

        A rigid-body mode (w_r = 0) makes the receptance infinite at 0 Hz.
        """
        _, den = self._modal_factors(freq_hz)
        with np.errstate(divide="ignore", invalid="ignore"):
            return self._sum(1.0 / den, resp, ref)

    def accelerance(self, freq_hz: np.ndarray, resp: np.ndarray, ref: np.ndarray) -> np.ndarray:
        """Accelerance H[f, i, j] ((m/s^2)/N) = -w^2 times the receptance.

        The factor -w^2/den of a rigid-body mode tends to 1 (the mass line) as w -> 0; at
        0 Hz it is taken as that limit, and an elastic mode contributes 0 there.
        """
        w2, den = self._modal_factors(freq_hz)
        zero = den == 0
        factors = -w2 / np.where(zero, 1.0, den)
        factors[zero] = 1.0
        return self._sum(factors, resp, ref)


BETA_L = np.array([4.730040745, 7.853204624, 10.995607838, 14.137165491, 17.278759657,
                   20.420352245, 23.561944902, 26.703537556])


def uniform_beam_modes(length_m: float, mass_kg: float, f1_hz: float, x_m: np.ndarray,
                       zeta1: float = 0.005, suspension_hz: tuple[float, float] = (2.0, 3.5),
                       n_bending: int = 8):
    """Build the ModalModel of a free-free uniform beam on a soft suspension.

    Two suspension (rigid) modes and ``n_bending`` bending modes at ``x_m``,
    f_n = f1 (b_n L / b_1 L)^2, shapes
    phi_n(x) = [cosh bx + cos bx - s_n (sinh bx + sin bx)] / sqrt(m) with
    s_n = (cosh bL - cos bL) / (sinh bL - sin bL) (int_0^L phi^2 rho A dx = 1).
    Damping: 3 % on the suspension modes, zeta1 (f / f1)^0.3 on bending.

    Parameters
    ----------
    length_m : float
        Beam length L, m.
    mass_kg : float
        Beam mass m, kg.
    f1_hz : float
        First bending frequency, Hz.
    x_m : np.ndarray
        (n,) points along the beam, m from one end.
    zeta1 : float, optional
        Damping ratio of the first bending mode.
    suspension_hz : tuple of float, optional
        Frequencies of the two suspension modes, Hz.
    n_bending : int, optional
        Number of bending modes (at most 8).

    Returns
    -------
    ModalModel
        Mass-normalised modes at ``x_m``, rigid ones first.
    """
    x = np.asarray(x_m, dtype=float)[:, None]
    bl = BETA_L[:n_bending][None, :]
    b = bl / length_m
    s = (np.cosh(bl) - np.cos(bl)) / (np.sinh(bl) - np.sin(bl))
    bend = (np.cosh(b * x) + np.cos(b * x) - s * (np.sinh(b * x) + np.sin(b * x))) / np.sqrt(
        mass_kg)
    trans = np.full((x.shape[0], 1), 1 / np.sqrt(mass_kg))
    rot = np.sqrt(12 / (mass_kg * length_m**2)) * (x - length_m / 2)
    f_bend = f1_hz * (BETA_L[:n_bending] / BETA_L[0]) ** 2
    freq = np.r_[suspension_hz, f_bend]
    zeta = np.r_[0.03, 0.03, zeta1 * (f_bend / f1_hz) ** 0.3]
    return ModalModel(freq, zeta, np.hstack([trans, rot, bend]), x[:, 0])
