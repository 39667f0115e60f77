"""Mass and Stiffness Skyline Optimization (O'Callahan; docs/method.md).

With expanded, mass-normalised test shapes E (n, m) and Omega^2 = diag(w_r^2):

    (1)  P K_I - Q M_I = 0,  P = E E^T, Q = E Omega^2 E^T
    (2)  E^T M_I E = I                 (r <= s)
    (3)  E^T K_I E = Omega^2           (r <= s, elastic modes only)
    (4)  t^T M_I t = weighed mass      (optional; t = rigid translation)

Since P K - Q M = E (E^T K - Omega^2 E^T M) and E has full column rank, (1) holds iff
E^T K_I - Omega^2 E^T M_I = 0; that m x n form is what is assembled, so nothing n x n (let
alone n^2 x n^2) is formed. Each element matrix touches 4 DOFs, so the coefficient of an
element unknown in mode r's rows is the 4-vector E[c_i, r]^T k_i placed at c_i (sparse).

Dimensionless blocks: rows of (1) are divided by w_r^2 and by sqrt(M_S[k, k]) of their DOF,
rows of (3) by w_r w_s, (4) by the reference mass; then each block is scaled to unit
Frobenius norm times a user weight (reported as ``weights``).

Two forms of unknowns, both inside the assembly skyline:
  * element factors (``msso_elements``): K_I = K_S + sum beta_i k_i, M_I = M_S + sum alpha_i m_i
    with separable groups (factors.py); d = -(reference residual);
  * symmetric skyline coefficients (``msso_skyline``): every K_I, M_I entry (i <= j) that the
    assembly touches, scaled by sqrt(|A_ii A_jj|), minimum-norm change.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from updating.model.assembly import BatModel, attachment_matrices, skyline_mask
from updating.msso.factors import (
    ElementFactors,
    Mass,
    Stiffness,
    choose_groups,
    factors_from_vector,
    group_matrices,
    is_stiffness,
)
from updating.msso.regularisation import RANK_TOL, Regularisation, solve_regularised

BLOCKS = ("eigen", "mass_norm", "stiffness_norm", "weighed_mass")


@dataclass(frozen=True)
class MssoResult:
    """Element-factor MSSO: factors, parameter groups, ranks and weights of the blocks."""

    factors: ElementFactors
    groups: tuple[str, ...]
    y: np.ndarray
    rank: int
    block_ranks: dict
    weights: dict
    lam: float
    residual_before: float
    residual_after: float
    bounded: bool
    singular_values: np.ndarray = field(repr=False)


def sparse_matrices(model: BatModel) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """K_S, M_S as sparse matrices (element parts plus attachments)."""
    d = model.dofs
    rows = np.broadcast_to(d[:, :, None], (model.n_elements, 4, 4)).ravel()
    cols = np.broadcast_to(d[:, None, :], (model.n_elements, 4, 4)).ravel()
    p = model.parts
    n = model.n_dof
    K = sp.coo_matrix(((p.k_bend + p.k_shear).ravel(), (rows, cols)), shape=(n, n)).tocsr()
    M = sp.coo_matrix(((p.m_trans + p.m_rot).ravel(), (rows, cols)), shape=(n, n)).tocsr()
    if model.attachments:
        Ka, Ma = attachment_matrices(model)
        K, M = K + sp.csr_matrix(Ka), M + sp.csr_matrix(Ma)
    return K, M


def _check_modes(E: np.ndarray, omega2: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    E = np.asarray(E, dtype=float)
    omega2 = np.asarray(omega2, dtype=float).ravel()
    if E.ndim != 2 or E.shape[0] != n or E.shape[1] != omega2.size:
        raise ValueError(f"MSSO: shapes must be (n_dof={n}, m) with m = len(omega2)")
    return E, omega2


def _pairs(m: int) -> tuple[np.ndarray, np.ndarray]:
    return np.triu_indices(m)


def _element_blocks(model: BatModel, E: np.ndarray, omega2: np.ndarray,
                    groups: tuple[str, ...], weighed_mass_kg: float | None):
    """Dimensionless blocks (coefficients, right-hand sides) of the element form."""
    n, m, ne = model.n_dof, E.shape[1], model.n_elements
    K, M = sparse_matrices(model)
    el = np.flatnonzero(omega2 > 0)
    row_scale = 1.0 / np.sqrt(M.diagonal())
    Ed = E[model.dofs]  # (e, 4, m)
    iu, ju = _pairs(m)
    both = (omega2[iu] > 0) & (omega2[ju] > 0)
    w_rs = np.sqrt(omega2[iu[both]] * omega2[ju[both]])
    cols_eig, rows_eig, vals_eig = [], [], []
    mass_cols, stiff_cols, wm_cols = [], [], []
    t = np.zeros(4)
    t[[0, 2]] = 1.0
    for k, g in enumerate(groups):
        A = group_matrices(model, g)  # (e, 4, 4)
        EA = np.einsum("eam,eab->emb", Ed, A)  # (e, m, 4): E[c,r]^T A
        sgn = 1.0 / omega2[el][None, :, None] if is_stiffness(g) else -1.0
        vals = (EA[:, el, :] * sgn) * row_scale[model.dofs][:, None, :]
        rows = el[None, :, None] * n + model.dofs[:, None, :]
        cols = np.broadcast_to(k * ne + np.arange(ne)[:, None, None], vals.shape)
        rows_eig.append(np.broadcast_to(rows, vals.shape).ravel())
        cols_eig.append(cols.ravel())
        vals_eig.append(vals.ravel())
        EAE = np.einsum("emb,ebs->ems", EA, Ed)  # (e, m, m)
        zero_m = np.zeros((iu.size, ne))
        zero_k = np.zeros((both.sum(), ne))
        if is_stiffness(g):
            mass_cols.append(zero_m)
            stiff_cols.append((EAE[:, iu[both], ju[both]] / w_rs).T)
            wm_cols.append(np.zeros((1, ne)))
        else:
            mass_cols.append(EAE[:, iu, ju].T)
            stiff_cols.append(zero_k)
            wm_cols.append((np.einsum("a,eab,b->e", t, A, t))[None, :])
    p = len(groups) * ne
    C1 = sp.coo_matrix((np.concatenate(vals_eig), (np.concatenate(rows_eig),
                        np.concatenate(cols_eig))), shape=(m * n, p)).tocsr()
    keep = np.repeat(omega2 > 0, n)
    C1 = C1[keep]
    EK, EM = (K.T @ E).T, (M.T @ E).T  # (m, n)
    R1 = (EK[el] / omega2[el][:, None] - EM[el]) * row_scale[None, :]
    d1 = -R1.ravel()
    EME, EKE = E.T @ (M @ E), E.T @ (K @ E)
    d2 = (np.eye(m) - EME)[iu, ju]
    d3 = ((np.diag(omega2) - EKE)[iu[both], ju[both]]) / w_rs
    blocks = {"eigen": (C1, d1), "mass_norm": (np.hstack(mass_cols), d2),
              "stiffness_norm": (np.hstack(stiff_cols), d3)}
    if weighed_mass_kg is not None:
        m_ref = float(np.ones(n // 2) @ (M[0::2][:, 0::2] @ np.ones(n // 2)))
        blocks["weighed_mass"] = (np.hstack(wm_cols) / m_ref,
                                  np.array([(weighed_mass_kg - m_ref) / m_ref]))
    return blocks


def _block_rank(C) -> int:
    if C.shape[0] == 0:
        return 0
    G = C.T @ C
    G = G.toarray() if sp.issparse(G) else G
    w = np.linalg.eigvalsh(G)
    return int(np.sum(w > (RANK_TOL**2) * w.max())) if w.max() > 0 else 0


def _stack(blocks: dict, user_weights: dict | None):
    """Scale each block to unit Frobenius norm times its user weight, stack, report weights."""
    user = {b: 1.0 for b in BLOCKS} | (user_weights or {})
    mats, rhs, weights = [], [], {}
    for name, (C, d) in blocks.items():
        norm = sp.linalg.norm(C) if sp.issparse(C) else np.linalg.norm(C)
        w = user[name] / norm if norm > 0 else 0.0
        weights[name] = float(w)
        if w > 0:
            mats.append(sp.csr_matrix(C) * w)
            rhs.append(d * w)
    return sp.vstack(mats).tocsr(), np.concatenate(rhs), weights


def msso_elements(
    model: BatModel, shapes_n: np.ndarray, omega2: np.ndarray, *,
    stiffness: Stiffness | None = "element", mass: Mass | None = "element",
    regularisation: Regularisation = "gcv", weights: dict | None = None,
    weighed_mass_kg: float | None = None, lower: float = -0.95,
) -> MssoResult:
    """Element-factor MSSO: solve the stacked equations for per-element factors.

    Parameters
    ----------
    model : BatModel
        Reference model (its parts are k_i, m_i; factors are relative to it).
    shapes_n : (n_dof, m) array
        Expanded mass-normalised test shapes E.
    omega2 : (m,) array
        Test eigenvalues, rad^2/s^2 (0 for rigid-body modes, which enter only the mass
        normalisation).
    stiffness, mass : str or None
        Parameterisation (``factors.choose_groups``): "element" (the paper's one beta and
        one alpha per element), "separate", "bend" / "trans", or None.
    regularisation : {"gcv", "lcurve"}, float or None
        How the stacked system is solved (``regularisation.solve_regularised``).
    weights : dict, optional
        User weight per block name (``BLOCKS``), default 1.
    weighed_mass_kg : float, optional
        The bat's weighed mass; adds equation (4).
    lower : float
        Lower bound of every factor (> -1: no part may vanish).

    Returns
    -------
    MssoResult
        Factors, groups, ranks of the whole system and of each block, weights, lam,
        residual norms before and after.

    References
    ----------
    O'Callahan, J., Detection of Baseball Bat Alterations Using Mass and Stiffness Skyline
    Optimization Procedures, UMass Lowell (docs/method.md).
    """
    E, omega2 = _check_modes(shapes_n, omega2, model.n_dof)
    groups = choose_groups(model, stiffness, mass)
    blocks = _element_blocks(model, E, omega2, groups, weighed_mass_kg)
    C, d, w = _stack(blocks, weights)
    sol = solve_regularised(C, d, regularisation, lower=lower)
    ranks = {name: _block_rank(Cb) for name, (Cb, _) in blocks.items()}
    return MssoResult(factors_from_vector(sol.y, groups, model.n_elements), groups, sol.y,
                      sol.rank, ranks, w, sol.lam, float(np.linalg.norm(d)),
                      sol.residual_norm, sol.bounded, sol.singular_values)


@dataclass(frozen=True)
class SkylineResult:
    """Skyline-coefficient MSSO: symmetric sparse changes of K and M (inside the skyline)."""

    dK: sp.csr_matrix
    dM: sp.csr_matrix
    rank: int
    n_unknowns: int
    weights: dict
    lam: float
    residual_before: float
    residual_after: float


def msso_skyline(
    model: BatModel, shapes_n: np.ndarray, omega2: np.ndarray, *,
    regularisation: Regularisation = None, weights: dict | None = None,
) -> SkylineResult:
    """Coefficient MSSO: every symmetric K, M entry inside the skyline is an unknown.

    Unknown x_ij (i <= j) changes A_ij = A_ji by s_ij x_ij, s_ij = sqrt(|A_ii A_jj|) of the
    reference; the columns of the stacked system are then equilibrated to unit norm and the
    minimum-norm (or regularised) solution in those variables is returned as dK, dM.

    Parameters
    ----------
    model : BatModel
        Reference model; its assembly pattern is the skyline.
    shapes_n : (n_dof, m) array
        Expanded mass-normalised test shapes.
    omega2 : (m,) array
        Test eigenvalues, rad^2/s^2 (0 for rigid-body modes).
    regularisation : {"gcv", "lcurve"}, float or None
        As in ``msso_elements``; None: minimum norm.
    weights : dict, optional
        User weight per block name.

    Returns
    -------
    SkylineResult
        Sparse symmetric dK, dM, rank, number of unknowns, weights, lam, residual norms.
    """
    E, omega2 = _check_modes(shapes_n, omega2, model.n_dof)
    n, m = E.shape
    K, M = sparse_matrices(model)
    I, J = np.nonzero(np.triu(skyline_mask(model)))
    nu = I.size
    el = np.flatnonzero(omega2 > 0)
    row_scale = 1.0 / np.sqrt(M.diagonal())
    iu, ju = _pairs(m)
    both = (omega2[iu] > 0) & (omega2[ju] > 0)
    w_rs = np.sqrt(omega2[iu[both]] * omega2[ju[both]])
    off = I != J
    blocks_k, blocks_m = [], []
    for A, sign in ((K, 1.0), (M, -1.0)):
        diag = A.diagonal()
        s = np.sqrt(np.abs(diag[I] * diag[J]))
        # (1): unknown (i, j) enters row (r, j) with E[i, r] and, if i != j, row (r, i) with E[j, r]
        r_idx = np.repeat(el, nu)
        u_idx = np.tile(np.arange(nu), el.size)
        rows = [np.searchsorted(el, r_idx) * n + J[u_idx]]
        cols = [u_idx]
        scale = sign / omega2[r_idx] if sign > 0 else -np.ones(r_idx.size)
        vals = [E[I[u_idx], r_idx] * s[u_idx] * scale * row_scale[J[u_idx]]]
        o = off[u_idx]
        rows.append(np.searchsorted(el, r_idx[o]) * n + I[u_idx[o]])
        cols.append(u_idx[o])
        vals.append(E[J[u_idx[o]], r_idx[o]] * s[u_idx[o]] * scale[o] * row_scale[I[u_idx[o]]])
        C1 = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(el.size * n, nu)).tocsr()
        # (2)/(3): E_r^T dA E_s
        q = E[I][:, iu] * E[J][:, ju] + off[:, None] * E[J][:, iu] * E[I][:, ju]  # (nu, pairs)
        Cq = (q * s[:, None]).T
        blocks_k.append(C1) if sign > 0 else blocks_m.append(C1)
        if sign > 0:
            C3 = Cq[both] / w_rs[:, None]
        else:
            C2 = Cq
    EK, EM = (K.T @ E).T, (M.T @ E).T
    d1 = -((EK[el] / omega2[el][:, None] - EM[el]) * row_scale[None, :]).ravel()
    d2 = (np.eye(m) - E.T @ (M @ E))[iu, ju]
    d3 = ((np.diag(omega2) - E.T @ (K @ E))[iu[both], ju[both]]) / w_rs
    blocks = {
        "eigen": (sp.hstack([blocks_k[0], blocks_m[0]]).tocsr(), d1),
        "mass_norm": (np.hstack([np.zeros_like(C2), C2]), d2),
        "stiffness_norm": (np.hstack([C3, np.zeros_like(C3)]), d3),
    }
    C, d, w = _stack(blocks, weights)
    col = np.sqrt(np.asarray(C.multiply(C).sum(axis=0))).ravel()
    col = np.where(col > 0, col, 1.0)
    sol = solve_regularised(C @ sp.diags(1.0 / col), d, regularisation)
    x = sol.y / col
    out = []
    for k, A in enumerate((K, M)):
        diag = A.diagonal()
        v = x[k * nu:(k + 1) * nu] * np.sqrt(np.abs(diag[I] * diag[J]))
        D = sp.coo_matrix((np.concatenate([v, v[off]]), (np.concatenate([I, J[off]]),
                           np.concatenate([J, I[off]]))), shape=(n, n)).tocsr()
        out.append(D)
    return SkylineResult(out[0], out[1], sol.rank, 2 * nu, w, sol.lam, float(np.linalg.norm(d)),
                         sol.residual_norm)
