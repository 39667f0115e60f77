"""SEREP + MSSO passes: the paper's single pass and its iteration.

One pass (``expansion_pass``): pair the test modes with the (updated) model's modes by MAC at
the measured DOFs, expand the measured shapes to all DOFs with SEREP built on the rigid and
paired modes (updating.correlate.serep), solve MSSO for the element factors relative to that
model (updating.msso.skyline) and compose them, (1 + y) <- (1 + y)(1 + dy).

Iterated expansion (``iterate_expansion``): repeat the pass with the updated model's modes
until the largest factor increment is below a tolerance.
"""

from __future__ import annotations

import numpy as np

from updating.correlate.measured import MeasuredModes, dofs_at
from updating.correlate.pairing import align_signs
from updating.correlate.serep import paired_serep
from updating.model.assembly import BatModel
from updating.model.modes import model_modes
from updating.msso.factors import ElementFactors, apply_factors, zero_factors
from updating.msso.skyline import MssoResult, msso_elements


def expansion_pass(
    model: BatModel, test: MeasuredModes, factors: ElementFactors, n_rigid: int = 2,
    **msso_kw,
) -> tuple[ElementFactors, MssoResult, float]:
    """One SEREP + MSSO pass relative to the model updated by ``factors``.

    Parameters
    ----------
    model : BatModel
        Reference model; its nodes include the test points ``test.x_m``.
    test : MeasuredModes
        Measured elastic modes, mass-normalised.
    factors : ElementFactors
        Factors already found (zero for the paper's single pass).
    n_rigid : int
        Lowest model modes kept in the SEREP basis as rigid-body (or suspension) modes.
    **msso_kw
        Passed to ``msso_elements`` (parameter groups, regularisation, weights, mass).

    Returns
    -------
    (ElementFactors, MssoResult, float)
        The composed factors, the MSSO result and the SEREP condition number.
    """
    updated = apply_factors(model, factors)
    Phi = model_modes(updated).shapes
    dofs = dofs_at(model, test.x_m)
    idx, T = paired_serep(Phi, test.shapes, dofs, n_rigid)
    shapes = align_signs(Phi[np.ix_(dofs, idx)], test.shapes)
    res = msso_elements(updated, T.expand(shapes), test.omega2, **msso_kw)
    return factors.compose(res.factors), res, T.cond


def iterate_expansion(
    model: BatModel, test: MeasuredModes, n_iter: int = 5, tol: float = 1e-6, **msso_kw,
) -> tuple[ElementFactors, list[MssoResult]]:
    """Repeated expansion passes until the largest factor increment is below ``tol``."""
    f = zero_factors(model.n_elements)
    results = []
    for _ in range(n_iter):
        f_new, res, _ = expansion_pass(model, test, f, **msso_kw)
        results.append(res)
        step = max(np.max(np.abs(a - b)) for a, b in zip(f_new.as_tuple(), f.as_tuple(),
                                                          strict=True))
        f = f_new
        if step < tol:
            break
    return f, results
