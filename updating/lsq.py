"""The one bounded nonlinear least-squares driver of the updating stage, and its covariance.

    minimise  1/2 ||r(x)||^2   subject to  lower <= x <= upper

by scipy's trust-region reflective method (Branch, Coleman & Li 1999), and the linearised
parameter covariance at the solution

    C = s^2 (J^T J)^+ ,   s^2 = r^T r / dof   (dof = N - p unless given),

with the Moore-Penrose pseudo-inverse, so that a rank-deficient Jacobian (an unobservable
combination of parameters) gives a finite covariance on the observable part instead of an
error. Residuals already divided by their standard deviations take s^2 = 1.

Callers: the diagnosis fit (updating.diagnose.calibration), the change fit of an inspection
(updating.inspect.hypotheses) and, for the covariance only, the MSSO refinement
(updating.msso.iterate, whose Levenberg-Marquardt loop carries per-mode scales and a
one-sided step limit that scipy's bounds do not express).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares


@dataclass(frozen=True)
class LsqSolution:
    """Solution x, the residual r(x) and Jacobian J(x) there, and the number of evaluations."""

    x: np.ndarray
    residual: np.ndarray
    jac: np.ndarray
    nfev: int
    active: np.ndarray
    """(p,) -1 / +1 where a lower / upper bound holds the solution, else 0 (scipy's mask,
    or within ``held_within`` of the bound, ``solve_bounded``)."""

    @property
    def ssr(self) -> float:
        """Sum of squared residuals r^T r."""
        return float(self.residual @ self.residual)


def solve_bounded(
    fun: Callable[[np.ndarray], np.ndarray], x0: np.ndarray, lower: np.ndarray,
    upper: np.ndarray, *, jac: Callable[[np.ndarray], np.ndarray] | str = "2-point",
    margin: float | np.ndarray = 1e-9, held_within: float | np.ndarray = 0.0, **options,
) -> LsqSolution:
    """Bounded least squares from x0 (moved ``margin`` inside the bounds first).

    Parameters
    ----------
    fun : callable
        x -> residual vector r(x), already weighted.
    x0 : (p,) array
        Start.
    lower, upper : (p,) arrays
        Bounds.
    jac : callable or str
        x -> (N, p) Jacobian, or a finite-difference scheme name ("2-point").
    margin : float or (p,) array
        x0 is clipped to [lower + margin, upper - margin] (trust-region reflective needs a
        strictly feasible start).
    held_within : float or (p,) array
        A solution this close to a bound counts as held there (``active``): trust-region
        reflective iterates stay strictly inside, and a fit stopped by its tolerances can
        end a hair short of the bound the data push it against (scipy marks only x within
        ``xtol`` relative).
    **options
        Passed to ``scipy.optimize.least_squares`` (tolerances, ``x_scale``, ``diff_step``,
        ``max_nfev``).

    Returns
    -------
    LsqSolution
        x, residual and Jacobian at x, evaluations.

    References
    ----------
    Branch, M. A., Coleman, T. F., Li, Y. (1999), A subspace, interior, and conjugate gradient
    method for large-scale bound-constrained minimization problems, SIAM J. Sci. Comput. 21(1).
    """
    x0 = np.clip(np.asarray(x0, dtype=float), lower + margin, upper - margin)
    out = least_squares(fun, x0, jac=jac, bounds=(lower, upper), method="trf", **options)
    active = np.asarray(out.active_mask).copy()
    active[(active == 0) & (out.x - lower <= held_within)] = -1
    active[(active == 0) & (upper - out.x <= held_within)] = 1
    return LsqSolution(out.x, out.fun, out.jac, int(out.nfev), active)


def covariance(
    jac: np.ndarray, residual: np.ndarray | None = None, dof: float | None = None, *,
    s2_default: float = 1.0, rcond: float | None = None,
) -> np.ndarray:
    """Linearised covariance s^2 (J^T J)^+ of least-squares parameters.

    Parameters
    ----------
    jac : (N, p) array
        Jacobian of the weighted residual at the solution.
    residual : (N,) array, optional
        Weighted residual at the solution; None takes s^2 = ``s2_default`` (residuals
        already in units of their standard deviations).
    dof : float, optional
        Degrees of freedom of s^2 = r^T r / dof; default N - p. When it is not positive,
        s^2 = ``s2_default``.
    s2_default : float
        s^2 when it cannot be estimated from the residual.
    rcond : float, optional
        Relative cut-off of the pseudo-inverse's singular values (numpy's default if None).

    Returns
    -------
    (p, p) array
        The covariance (zeros (0, 0) when there are no parameters).
    """
    jac = np.asarray(jac, dtype=float)
    p = jac.shape[1]
    if p == 0:
        return np.zeros((0, 0))
    s2 = s2_default
    if residual is not None:
        dof = jac.shape[0] - p if dof is None else dof
        if dof > 0:
            s2 = float(residual @ residual) / dof
    jtj = jac.T @ jac
    return s2 * (np.linalg.pinv(jtj) if rcond is None else np.linalg.pinv(jtj, rcond=rcond))
