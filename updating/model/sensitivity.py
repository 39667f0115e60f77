"""First-order sensitivities of normal modes to changes of K and M.

For K phi_r = lambda_r M phi_r with phi_r^T M phi_r = 1, distinct eigenvalues and a change
(dK, dM) of the matrices (Fox and Kapoor 1968; Nelson 1976 for the complete expansion):

    d lambda_r = phi_r^T (dK - lambda_r dM) phi_r
    d phi_r    = sum_{s != r} phi_s phi_s^T (dK - lambda_r dM) phi_r / (lambda_r - lambda_s)
                 - 1/2 (phi_r^T dM phi_r) phi_r

The sum runs over every mode of the discrete model, so the expansion is exact to first order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg


@dataclass(frozen=True)
class ModeDerivatives:
    """Derivatives of the lowest modes with respect to k parameters.

    Attributes
    ----------
    d_lambda : numpy.ndarray
        (m, k) d lambda_r / d p_j, (rad/s)^2 per parameter unit.
    d_shapes : numpy.ndarray
        (len(rows), m, k) d phi_r / d p_j at the rows asked for (mass-normalised shapes).
    """

    d_lambda: np.ndarray
    d_shapes: np.ndarray


@dataclass(frozen=True)
class FullModes:
    """Every mode of (K, M): eigenvalues (N,), (rad/s)^2, and M-orthonormal vectors (N, N)."""

    lam: np.ndarray
    vectors: np.ndarray


def full_modes(K: np.ndarray, M: np.ndarray) -> FullModes:
    """Solve for every mode of (K, M), as the complete expansion needs.

    Parameters
    ----------
    K, M : numpy.ndarray
        (N, N) symmetric stiffness and positive definite mass matrices.

    Returns
    -------
    FullModes
        Eigenvalues ascending and their M-orthonormal vectors.
    """
    lam, vec = scipy.linalg.eigh(K, M)
    return FullModes(lam, vec)


def mode_derivatives(modes: FullModes, dK: np.ndarray, dM: np.ndarray, m: int,
                     rows: np.ndarray) -> ModeDerivatives:
    """Differentiate the lowest ``m`` modes for k changes of the matrices (module docstring).

    Parameters
    ----------
    modes : FullModes
        Every mode of the unchanged (K, M).
    dK, dM : numpy.ndarray
        (k, N, N) derivatives of K and M with respect to each parameter.
    m : int
        Number of lowest modes differentiated.
    rows : numpy.ndarray
        Degrees of freedom at which the shapes' derivatives are returned.

    Returns
    -------
    ModeDerivatives
        d lambda (m, k) and d phi at ``rows`` (len(rows), m, k).
    """
    lam, phi = modes.lam, modes.vectors
    wanted = phi[:, :m]
    G = phi.T @ (dK @ wanted)            # (k, N, m): phi_s^T dK phi_r
    H = phi.T @ (dM @ wanted)            # (k, N, m): phi_s^T dM phi_r
    lam_r = lam[:m]
    P = G - lam_r * H                    # phi_s^T (dK - lambda_r dM) phi_r
    r = np.arange(m)
    d_lambda = P[:, r, r].T              # (m, k)
    gap = lam_r[None, :] - lam[:, None]  # (N, m): lambda_r - lambda_s
    gap[r, r] = np.inf
    C = P / gap
    C[:, r, r] = -0.5 * H[:, r, r]
    d_shapes = np.moveaxis(phi[rows] @ C, 0, -1)
    return ModeDerivatives(d_lambda, d_shapes)
