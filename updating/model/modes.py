"""Free-free (or suspended) normal modes: K phi = w^2 M phi, phi^T M phi = I.

Rigid-body modes of an unsupported beam (translation w = 1, rotation w = x - x_c, theta = 1)
lie exactly in the null space of K; they are returned in that exact form, M-orthonormalised,
at 0 Hz, instead of the round-off-polluted eigenvectors of the solver.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse

from updating.model.assembly import BatModel, assemble


@dataclass(frozen=True)
class Modes:
    """Normal modes, ascending. shapes (n_dof, m) mass-normalised; freq_hz (m,); n_rigid."""

    freq_hz: np.ndarray
    shapes: np.ndarray
    n_rigid: int = 0

    @property
    def omega2(self) -> np.ndarray:
        """Return the squared circular frequencies (2 pi f)^2, (rad/s)^2."""
        return (2 * np.pi * self.freq_hz) ** 2

    def elastic(self) -> Modes:
        """Return the elastic modes alone (the rigid-body ones dropped)."""
        return Modes(self.freq_hz[self.n_rigid:], self.shapes[:, self.n_rigid:], 0)


def rigid_body_shapes(node_x_m: np.ndarray, M: np.ndarray) -> np.ndarray:
    """Exact rigid-body modes (n, 2): translation and rotation, M-orthonormal."""
    n = 2 * node_x_m.size
    R = np.zeros((n, 2))
    R[0::2, 0] = 1.0
    R[0::2, 1] = node_x_m
    R[1::2, 1] = 1.0
    # M-orthonormalise (Cholesky of the 2x2 Gram matrix)
    L = np.linalg.cholesky(R.T @ M @ R)
    return np.linalg.solve(L, R.T).T


DENSE_MAX_FLOPS = 4e6
"""Size n^2 m up to which ``column_quadratic_forms`` multiplies densely (about 1 ms)."""


def column_quadratic_forms(A: np.ndarray, V: np.ndarray) -> np.ndarray:
    """Compute diag(V^T A V), (m,), for a banded A (n, n) and V (n, m).

    A is read as a sparse matrix, so the cost is O(nnz(A) m + n^2) instead of the dense
    product's O(n^2 m) -- for all modes of a fine mesh (m = n) that is the difference between
    a fraction of the eigen-solution's time and as much again. Small problems (n^2 m below
    ``DENSE_MAX_FLOPS``) take the dense product: building the sparse matrix costs more there
    than it saves.
    """
    if A.shape[0] * V.shape[0] * V.shape[1] <= DENSE_MAX_FLOPS:
        return np.einsum("ij,ij->j", V, A @ V)
    return np.einsum("ij,ij->j", V, scipy.sparse.csr_array(A) @ V)


def rayleigh_quotients(K: np.ndarray, M: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """Return the Rayleigh quotients phi^T K phi / phi^T M phi of the columns of ``vec``, (m,).

    What the eigenvalues are read as: the solver's own carry an absolute error of order
    eps * lambda_max, large for fine meshes; the quotient's error is quadratic in the vector's.
    """
    return column_quadratic_forms(K, vec) / column_quadratic_forms(M, vec)


def rayleigh_freq_hz(K: np.ndarray, M: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """Return the frequencies sqrt(lambda) / (2 pi), Hz, of the columns of ``vec``.

    lambda their Rayleigh quotients (``rayleigh_quotients``), read as 0 below 0.
    """
    return np.sqrt(np.clip(rayleigh_quotients(K, M, vec), 0.0, None)) / (2 * np.pi)


def solve_modes(
    K: np.ndarray, M: np.ndarray, node_x_m: np.ndarray | None = None, n_modes: int | None = None,
) -> Modes:
    """Solve for the lowest ``n_modes`` modes of (K, M) (all by default).

    The one eigen-solution of the project (model, diagnosis, inspection predictor and MSSO all
    call it). When ``node_x_m`` is given the structure is taken as free-free: its two lowest
    modes are returned as the exact rigid-body shapes at 0 Hz and the elastic modes follow.
    """
    free = node_x_m is not None
    n = K.shape[0]
    m = n if n_modes is None else min(n, n_modes)
    # all modes: the divide-and-conquer driver (its vectors are M-orthonormal to round-off,
    # which complete-expansion sensitivities need); a subset: the selective driver
    subset = None if n_modes is None else [0, m - 1]
    _, vec = scipy.linalg.eigh(K, M, subset_by_index=subset)
    lam = rayleigh_quotients(K, M, vec)
    n_rigid = 0
    if free and m >= 2:
        n_rigid = 2
        vec = np.column_stack([rigid_body_shapes(node_x_m, M), vec[:, 2:]])
        lam = np.concatenate([[0.0, 0.0], lam[2:]])
    freq = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
    return Modes(freq, vec, n_rigid)


def model_modes(model: BatModel, n_modes: int | None = None, **changes) -> Modes:
    """Modes of the assembled model (element changes as in ``assemble``)."""
    K, M = assemble(model, **changes)
    free = not any(a.k_n_per_m for a in model.attachments)
    return solve_modes(K, M, model.node_x_m if free else None, n_modes)
