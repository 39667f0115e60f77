"""One peak holding both bending planes' members of a pair: the planes' mix.

A hammer and a single-axis accelerometer along the angle theta from bending plane 1 see
plane p's mode r with the residue t_p^2 phi_p(x_s) phi_p(x_j), t = (cos theta, sin theta)
(updating.simulate.solid_test). When the pair's split is below its half-power width the modal
fit finds one pole. Summed over the two planes, the pair's accelerance is, to first order in
the split, one mode whose squared frequency is the residue-weighted mean,

    lam_mix = sum_p w_p lam_p,    w_p = t_p^2 phi_p(x_s)^2 / D,    D = sum_p t_p^2 phi_p(x_s)^2,

(the first moment of sum_p A_p / (lam_p - w^2) about its poles) and whose mass-normalised
shape, the residue row scaled by the root of the driving-point residue, is

    y_mix(x) = sum_p t_p^2 phi_p(x_s) phi_p(x) / sqrt(D),

the full amplitude of one plane when the planes' shapes agree. Tapped at 45 degrees the mix is
the mean of the two planes' squared frequencies; in a grain plane (theta 0) it is plane 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PlaneMix:
    """The planes' mix of every pair, with its derivatives.

    Attributes
    ----------
    freq_hz : np.ndarray
        (k,) frequencies, Hz.
    shapes : np.ndarray
        (n_points, k) mass-normalised shapes at the test points.
    dlnf : np.ndarray
        (p, k) d ln f / d parameter.
    dshapes : np.ndarray
        (p, n_points, k) d shape / d parameter.
    """

    freq_hz: np.ndarray
    shapes: np.ndarray
    dlnf: np.ndarray
    dshapes: np.ndarray


def plane_mix(
    freq_hz: tuple[np.ndarray, np.ndarray], shapes: tuple[np.ndarray, np.ndarray],
    dlnf: tuple[np.ndarray, np.ndarray], dshapes: tuple[np.ndarray, np.ndarray],
    theta_rad: float, theta_index: int | None, drive: int,
) -> PlaneMix:
    """Mix the two planes' modes of each pair as one peak sees them (module docstring).

    Parameters
    ----------
    freq_hz : tuple of ndarray
        (k,) each plane's frequencies, Hz.
    shapes : tuple of ndarray
        (n_points, k) each plane's mass-normalised shapes (not scaled by the angle).
    dlnf : tuple of ndarray
        (p, k) each plane's d ln f / d parameter.
    dshapes : tuple of ndarray
        (p, n_points, k) each plane's d shape / d parameter.
    theta_rad : float
        The tap angle from plane 1, rad.
    theta_index : int or None
        The angle's row among the parameters (None: not a free parameter).
    drive : int
        The driving point's row among the test points.

    Returns
    -------
    PlaneMix
        Frequencies, shapes and their derivatives.
    """
    t2 = np.array([np.cos(theta_rad) ** 2, np.sin(theta_rad) ** 2])[:, None]  # (2, 1)
    dt2 = np.zeros((dlnf[0].shape[0], 2, 1))  # d t_p^2 / d parameter
    if theta_index is not None:
        s2 = np.sin(2 * theta_rad)
        dt2[theta_index] = np.array([[-s2], [s2]])
    u = np.stack(shapes)  # (2, n, k)
    du = np.stack(dshapes, axis=1)  # (p, 2, n, k)
    us, dus = u[:, drive], du[:, :, drive]  # (2, k), (p, 2, k)
    lam = np.stack(freq_hz) ** 2  # (2, k)
    dlam = 2 * lam * np.stack(dlnf, axis=1)  # (p, 2, k)
    a = t2 * us  # residue factor t_p^2 phi_p(x_s)
    da = dt2 * us + t2 * dus
    D = np.sum(a * us, axis=0)  # (k,)
    dD = np.sum(dt2 * us**2 + 2 * t2 * us * dus, axis=1)  # (p, k)
    w = a * us / D
    dw = (da * us + a * dus) / D - w * (dD / D)[:, None, :]
    lam_mix = np.sum(w * lam, axis=0)
    dlnf_mix = np.sum(dw * lam + w * dlam, axis=1) / (2 * lam_mix)
    root = np.sqrt(D)
    y = np.einsum("pk,pnk->nk", a, u) / root
    dy = ((np.einsum("qpk,pnk->qnk", da, u) + np.einsum("pk,qpnk->qnk", a, du)) / root
          - 0.5 * y[None] * (dD / D)[:, None, :])
    return PlaneMix(np.sqrt(lam_mix), y, dlnf_mix, dy)
