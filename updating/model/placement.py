"""Measurement-point selection by effective independence (Kammer 1991, J. Guid. Control Dyn.).

Candidates are translational DOFs; with target shapes Phi (c x m) the effective-independence
values E_D = diag(Phi (Phi^T Phi)^-1 Phi^T) measure each candidate's share of the Fisher
information; the candidate with the smallest E_D is removed until ``n_points`` remain.
"""

from __future__ import annotations

import numpy as np


def effective_independence(shapes: np.ndarray, n_points: int) -> np.ndarray:
    """Indices (ascending) of the ``n_points`` rows of ``shapes`` (c x m) kept by EfI."""
    phi = np.asarray(shapes, dtype=float)
    if n_points < phi.shape[1]:
        raise ValueError("need at least as many points as target modes")
    keep = np.arange(phi.shape[0])
    while keep.size > n_points:
        p = phi[keep]
        ed = np.einsum("ij,ij->i", p @ np.linalg.pinv(p.T @ p), p)
        keep = np.delete(keep, int(np.argmin(ed)))
    return keep
