"""Modal assurance criterion (Allemang and Brown, 1982).

MAC(a_r, b_s) = |a_r^H b_s|^2 / ((a_r^H a_r) (b_s^H b_s))
"""

from __future__ import annotations

import numpy as np


def mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return the MAC matrix between the columns of a and b.

    MAC_ij = |a_i^H b_j|^2 / ((a_i^H a_i) (b_j^H b_j)) (Allemang and Brown 1982).

    Parameters
    ----------
    a : ndarray
        (n, r) shapes.
    b : ndarray
        (n, s) shapes.

    Returns
    -------
    ndarray
        (r, s), each entry in 0..1.
    """
    a = np.asarray(a).reshape(np.shape(a)[0], -1)
    b = np.asarray(b).reshape(np.shape(b)[0], -1)
    if a.shape[0] != b.shape[0]:
        raise ValueError(f"mode sets have {a.shape[0]} and {b.shape[0]} points")
    num = np.abs(np.conj(a).T @ b) ** 2
    den = np.outer(np.sum(np.abs(a) ** 2, axis=0), np.sum(np.abs(b) ** 2, axis=0))
    return num / np.where(den > 0, den, np.inf)


def auto_mac(a: np.ndarray) -> np.ndarray:
    """Return the MAC of a mode set with itself.

    Parameters
    ----------
    a : ndarray
        (n, r) shapes.

    Returns
    -------
    ndarray
        (r, r), ones on the diagonal.
    """
    return mac(a, a)
