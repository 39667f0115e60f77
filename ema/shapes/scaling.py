"""Residues -> mass-normalised mode shapes through the driving point.

For real normal modes the receptance is

    H_jk(w) = sum_r phi_jr phi_kr / (w_r^2 - w^2 + 2 i zeta_r w_r w)

and (accelerance = -w^2 H, mobility = i w H: same modes, same scaling). Its pole-residue form
A_r / (i w - lambda_r) + conj(A_r) / (i w - conj(lambda_r)) with lambda_r = -zeta_r w_r + i w_d
has A_jk,r = phi_jr phi_kr / (2 i w_d), because (s - lambda)(s - conj lambda) =
w_r^2 - w^2 + 2 i zeta w_r w at s = i w and 1 / ((s - lambda)(s - conj lambda)) =
(1 / (s - lambda) - 1 / (s - conj lambda)) / (2 i w_d).  The *modal constant* in real-mode
convention is therefore rA_jk,r = 2 i w_d A_jk,r = phi_jr phi_kr, and with the driving point d

    phi_dr = sqrt(rA_dd,r),     phi_kr = rA_dk,r / phi_dr.

(Taking phi = A / sqrt(A_dd), as one public tool does, is off by the factor sqrt(2 i w_d).)
For complex modes the same formulas define the complex shapes in the same units (1/sqrt(kg));
the principal square root makes the driving-point entry of a real mode real and positive.
"""

from __future__ import annotations

import numpy as np


def modal_constants(residue: np.ndarray, poles: np.ndarray) -> np.ndarray:
    """Return the real-mode-convention modal constants rA = 2 i w_d A.

    Parameters
    ----------
    residue : ndarray
        (..., m) residues A (receptance pole-residue form).
    poles : ndarray
        (m,) continuous poles, rad/s.

    Returns
    -------
    ndarray
        (..., m) modal constants, 1/kg.
    """
    return 2j * np.asarray(poles).imag * np.asarray(residue)


def mass_normalised_shapes(
    residue_row: np.ndarray, poles: np.ndarray, driving_index: int
) -> np.ndarray:
    """Return mass-normalised complex shapes from the residues of one driving-point row.

    Parameters
    ----------
    residue_row : ndarray
        (n, m) residues: ``residue_row[k, r]`` is that of mode r in H_dk (or H_kd).
    poles : ndarray
        (m,) continuous poles, rad/s.
    driving_index : int
        k = d, the driving point's row.

    Returns
    -------
    ndarray
        (n, m) complex shapes, 1/sqrt(kg).
    """
    ra = modal_constants(residue_row, poles)
    phi_d = np.sqrt(ra[driving_index])
    return ra / np.where(phi_d != 0, phi_d, np.inf)[None, :]


def unscaled_shapes(residue_row: np.ndarray, poles: np.ndarray) -> np.ndarray:
    """Return shapes known up to a factor, from one row of residues without its driving point.

    rA_jk = phi_j phi_k along k is the shape times phi_j (unknown): each column is divided by
    its largest-magnitude entry (that entry becomes 1).

    Parameters
    ----------
    residue_row : ndarray
        (n, m) residues of one row.
    poles : ndarray
        (m,) continuous poles, rad/s.

    Returns
    -------
    ndarray
        (n, m) complex shapes, largest entry 1.
    """
    ra = modal_constants(residue_row, poles)
    if ra.size == 0:
        return ra
    big = ra[np.argmax(np.abs(ra), axis=0), np.arange(ra.shape[1])]
    return ra / np.where(big != 0, big, np.inf)[None, :]


def fix_sign(
    shapes: np.ndarray, driving_index: int | None, min_relative: float = 1e-3
) -> np.ndarray:
    """Flip each real shape so its driving-point entry is positive.

    When the driving point is (near) a node of the mode (|phi_d| < min_relative max|phi|), or
    there is none (``driving_index`` None), the largest-magnitude entry is made positive.

    Parameters
    ----------
    shapes : ndarray
        (n, m) real shapes.
    driving_index : int or None
        The driving point's row.
    min_relative : float
        Below this fraction of the largest entry the driving point counts as a node.

    Returns
    -------
    ndarray
        (n, m) the shapes with their signs fixed.
    """
    s = np.array(shapes, dtype=float, copy=True)
    if s.size == 0:
        return s
    big = s[np.argmax(np.abs(s), axis=0), np.arange(s.shape[1])]
    dp = big if driving_index is None else s[driving_index]
    ref = np.where(np.abs(dp) >= min_relative * np.abs(big), dp, big)
    return s * np.where(ref < 0, -1.0, 1.0)[None, :]
