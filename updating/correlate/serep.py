"""System Equivalent Reduction Expansion Process (O'Callahan, Avitabile, Riemer 1989).

With U_nm the reference modes chosen as the basis (rigid-body modes plus the modes paired
with the test modes) and U_am their rows at the measured DOFs:

    T = U_nm pinv(U_am),   E_n = T E_a,   M_a = T^T M T,   K_a = T^T K T.

The expansion is exact for any test shape in the span of the basis; the basis must not be
larger than the number of sensors. ``cond`` = cond(U_am) tells how well the sensors see it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.correlate.pairing import paired_elastic


@dataclass(frozen=True)
class Serep:
    """SEREP transformation T (n, a) from the measured DOFs to all DOFs."""

    T: np.ndarray
    dofs_a: np.ndarray
    basis: np.ndarray  # U_nm (n, k)
    cond: float

    def expand(self, shapes_a: np.ndarray) -> np.ndarray:
        """E_n = T E_a."""
        return self.T @ shapes_a

    def reduce(self, matrix: np.ndarray) -> np.ndarray:
        """T^T A T (e.g. the reduced mass for the pseudo-orthogonality check)."""
        return self.T.T @ matrix @ self.T


def serep(basis_n: np.ndarray, dofs_a: np.ndarray) -> Serep:
    """SEREP transformation T = U_n pinv(U_a).

    Parameters
    ----------
    basis_n : (n, k) array
        Reference mode shapes at all DOFs (rigid-body modes and the modes paired with the
        test), mass-normalised.
    dofs_a : (a,) int array
        Measured DOFs (a >= k).

    Returns
    -------
    Serep
        T (n, a), the DOFs, the basis and cond(U_a); ``expand`` gives E_n = T E_a and
        ``reduce`` the reduced matrix T^T A T.

    Raises ValueError if the basis has more modes than sensors or the sensors cannot see it.

    References
    ----------
    O'Callahan, J., Avitabile, P., Riemer, R. (1989), System Equivalent Reduction Expansion
    Process (SEREP), Proc. 7th International Modal Analysis Conference.
    """
    dofs_a = np.asarray(dofs_a, dtype=int)
    U_a = basis_n[dofs_a]
    k, a = basis_n.shape[1], dofs_a.size
    if k > a:
        raise ValueError(f"SEREP basis of {k} modes needs at least {k} measured DOFs, got {a}")
    s = np.linalg.svd(U_a, compute_uv=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else np.inf
    if not np.isfinite(cond) or cond > 1e10:
        raise ValueError(f"SEREP: the {a} measured DOFs cannot separate the {k} basis modes "
                         f"(cond {cond:.2e})")
    return Serep(basis_n @ np.linalg.pinv(U_a), dofs_a, basis_n, cond)


def paired_serep(model_shapes: np.ndarray, test_shapes: np.ndarray, dofs_a: np.ndarray,
                 n_rigid: int) -> tuple[np.ndarray, Serep]:
    """Build SEREP on the test's own modes.

    The basis is the ``n_rigid`` rigid-body (or suspension) modes and the model modes paired
    with the test modes by MAC at ``dofs_a`` (``correlate.pairing.paired_elastic``).

    Parameters
    ----------
    model_shapes : (n, k) array
        The model's modes, ascending, mass-normalised.
    test_shapes : (a, m) array
        Measured shapes at ``dofs_a``.
    dofs_a : (a,) int array
        Measured translational DOFs.
    n_rigid : int
        Leading model modes taken into the basis unpaired.

    Returns
    -------
    (int array, Serep)
        The paired model mode of each test mode, and the transformation.
    """
    idx = paired_elastic(model_shapes, test_shapes, dofs_a, n_rigid)
    basis = np.column_stack([model_shapes[:, :n_rigid], model_shapes[:, idx]])
    return idx, serep(basis, dofs_a)
