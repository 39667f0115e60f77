"""Optional maximum-likelihood refinement of the poles (variable projection).

With the poles fixed the FRF model of ``ema.shapes.lsfd`` is linear in the residues and residual
terms, so the residues are eliminated (solved by LSFD at every evaluation) and only the poles
are iterated (Golub and Pereyra's variable projection):

    min over (f_r, zeta_r) of  sum_j sum_f |H_j(f) - H_j(f; poles, LSFD residues)|^2 / s_j^2

For complex Gaussian noise of variance s_j^2 on FRF j this is the maximum-likelihood estimate
of the poles; s_j is taken from the misfit of the starting LSFD (so the weights equalise the
FRFs' noise, not their amplitude). Only lines within ``window`` half-power widths of a mode
enter the cost. The covariance of the parameters, (J^T J)^-1 at the optimum, gives
Cramer-Rao-type standard deviations of the frequencies and damping ratios.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ema.shapes.lsfd import lsfd


@dataclass(frozen=True)
class RefinedPoles:
    """Refined poles and their standard deviations from the least-squares covariance."""

    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    freq_std_hz: np.ndarray
    damping_std: np.ndarray
    pole: np.ndarray
    extra_pole: np.ndarray
    n_eval: int


def _poles(theta: np.ndarray) -> np.ndarray:
    """Theta = (ln f_r, logit zeta_r): any real theta is a stable underdamped pole."""
    m = theta.size // 2
    wn = 2 * np.pi * np.exp(theta[:m])
    z = _zeta(theta[m:])
    return -z * wn + 1j * wn * np.sqrt(1 - z**2)


def _zeta(u: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-u))


def _theta(freq_hz: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    return np.r_[np.log(freq_hz), np.log(zeta / (1 - zeta))]


def refine_poles(
    freq_hz: np.ndarray,
    frf: np.ndarray,
    freq0_hz: np.ndarray,
    damping0: np.ndarray,
    quantity: str,
    band_hz: tuple[float, float],
    lower: bool = True,
    extra_poles: np.ndarray | None = None,
    window: float = 10.0,
    max_nfev: int = 30,
) -> RefinedPoles:
    """Refine (f_r, zeta_r) of all modes together against the FRFs by maximum likelihood.

    The residues are eliminated (variable projection, see the module docstring); ``extra_poles``
    (computational poles of cut modes) are refined with them and returned in ``extra_pole``;
    their damping must be positive.

    Parameters
    ----------
    freq_hz : ndarray
        (F,) lines, Hz.
    frf : ndarray
        (F, n_frf) complex FRFs of ``quantity``.
    freq0_hz, damping0 : ndarray
        (m,) starting natural frequencies (Hz) and damping ratios.
    quantity : str
        "receptance", "mobility" or "accelerance".
    band_hz : tuple of float
        (lo, hi) lines used, Hz.
    lower : bool
        Include the lower residual terms.
    extra_poles : ndarray, optional
        (k,) computational poles, rad/s.
    window : float
        Half-power half-widths about each mode whose lines weigh in.
    max_nfev : int
        Most function evaluations of the least-squares solver.

    Returns
    -------
    RefinedPoles
        The refined poles and their least-squares standard deviations.
    """
    freq_hz = np.asarray(freq_hz, dtype=float)
    frf = np.asarray(frf, dtype=complex).reshape(freq_hz.size, -1)
    extra = np.zeros(0, complex) if extra_poles is None else np.asarray(extra_poles, complex)
    n_modes = np.size(freq0_hz)
    # the computational poles (cut modes at the band edges) are refined too, not reported
    keep = (extra.imag > 0) & (extra.real < 0)
    extra = extra[keep]
    f0 = np.r_[np.asarray(freq0_hz, dtype=float), np.abs(extra) / (2 * np.pi)]
    z0 = np.r_[np.asarray(damping0, dtype=float), -extra.real / np.abs(extra)]
    sel = (freq_hz >= band_hz[0]) & (freq_hz <= band_hz[1]) & (freq_hz > 0)
    df = freq_hz[1] - freq_hz[0]
    width = np.maximum(window * z0 * f0, 5 * df)
    near = np.any(np.abs(freq_hz[:, None] - f0[None, :]) <= width[None, :], axis=1) & sel
    f, h = freq_hz[near], frf[near]
    start = lsfd(f, h, _poles(_theta(f0, z0)), quantity, band_hz, lower=lower)
    sigma = np.sqrt(np.mean(np.abs(h - start.synth) ** 2, axis=0))
    sigma = np.where(sigma > 0, sigma, 1.0)

    def residual(theta: np.ndarray) -> np.ndarray:
        fit = lsfd(f, h, _poles(theta), quantity, band_hz, lower=lower)
        r = (h - fit.synth) / sigma[None, :]
        return np.concatenate([r.real.ravel(), r.imag.ravel()])

    theta0 = _theta(f0, z0)
    sol = least_squares(residual, theta0, method="lm", x_scale="jac", max_nfev=max_nfev)
    m = f0.size
    jac = sol.jac
    dof = max(sol.fun.size - theta0.size, 1)
    s2 = float(sol.fun @ sol.fun) / dof
    cov = np.linalg.pinv(jac.T @ jac) * s2  # pinv: a weakly determined cut mode stays finite
    std = np.sqrt(np.clip(np.diag(cov), 0, None))
    fr = np.exp(sol.x[:m])
    zr = _zeta(sol.x[m:])
    k = n_modes
    return RefinedPoles(
        freq_hz=fr[:k],
        damping_ratio=zr[:k],
        freq_std_hz=fr[:k] * std[:k],
        damping_std=zr[:k] * (1 - zr[:k]) * std[m : m + k],
        pole=_poles(sol.x)[:k],
        extra_pole=_poles(sol.x)[k:],
        n_eval=int(sol.nfev),
    )
