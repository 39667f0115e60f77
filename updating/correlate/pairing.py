"""Pairing test modes with model modes by the Modal Assurance Criterion, and a scaling check.

    MAC(a, b) = |a^H b|^2 / ((a^H a)(b^H b))

Pseudo-orthogonality of test shapes scaled to unit modal mass, with the SEREP-reduced mass
M_a = T^T M T:  POC = E_a^T M_a E_a ~ I (off-diagonals show shape error, the diagonal the
scaling error).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize

from ema.shapes.mac import mac


@dataclass(frozen=True)
class Pairing:
    """test mode j pairs with model mode ``model_index[j]`` with MAC ``mac[j]``."""

    model_index: np.ndarray
    mac: np.ndarray


def pair_modes(model_shapes_a: np.ndarray, test_shapes_a: np.ndarray,
               min_mac: float = 0.5) -> Pairing:
    """Pair each test mode with a distinct model mode maximising the total MAC (Hungarian).

    Both shape sets are sampled at the same DOFs. Raises ValueError if a test mode finds no
    model mode with MAC >= min_mac.
    """
    m = mac(test_shapes_a, model_shapes_a)
    if m.shape[0] > m.shape[1]:
        raise ValueError(f"{m.shape[0]} test modes but only {m.shape[1]} model modes to pair")
    rows, cols = scipy.optimize.linear_sum_assignment(-m)
    index = cols[np.argsort(rows)]
    values = m[np.arange(m.shape[0]), index]
    bad = np.flatnonzero(values < min_mac)
    if bad.size:
        raise ValueError(f"test mode {bad[0] + 1} pairs with no model mode (best MAC "
                         f"{values[bad[0]]:.2f} < {min_mac})")
    return Pairing(index, values)


def align_signs(reference: np.ndarray, shapes: np.ndarray) -> np.ndarray:
    """Flip columns of ``shapes`` so that each has a non-negative dot product with reference."""
    s = np.sign(np.sum(reference * shapes, axis=0))
    return shapes * np.where(s == 0, 1.0, s)


@dataclass(frozen=True)
class Orthogonality:
    """POC matrix and its worst deviations from I."""

    poc: np.ndarray
    max_offdiag: float
    max_diag_error: float


def pseudo_orthogonality(shapes_a: np.ndarray, reduced_mass: np.ndarray) -> Orthogonality:
    """E_a^T M_a E_a for mass-normalised test shapes and the reduced mass M_a = T^T M T."""
    poc = shapes_a.T @ reduced_mass @ shapes_a
    off = poc - np.diag(np.diag(poc))
    return Orthogonality(poc, float(np.max(np.abs(off), initial=0.0)),
                         float(np.max(np.abs(np.diag(poc) - 1.0))))
