"""Beyond one MSSO pass: the nonlinear least-squares refinement of the element factors.

(The SEREP + MSSO passes it starts from are in updating.msso.expansion.)

Refinement: Levenberg-Marquardt fit of the exact model (sections rebuilt with the factors,
``updating.model.assembly.scale_sections``) to the measured data directly, with residuals

    r_f = (lam_r(y) / lam_r^test - 1) / (2 sigma_f)
    r_s = (c_r phi_r(y)[a] - psi_r) / (sigma_s rms(psi_r))      (c_r = 1 if mass-normalised)
    r_p = (D y, y / 10) / sigma_prior   (prior: differences between neighbouring elements
                                         and, weakly, the change itself; see prior_matrix)

and analytic eigen-sensitivities (Fox & Kapoor 1968; complete modal expansion):

    dlam_r/dp = phi_r^T (dK/dp - lam_r dM/dp) phi_r
    dphi_r/dp = sum_{s != r} phi_s phi_s^T (dK/dp - lam_r dM/dp) phi_r / (lam_r - lam_s)
                - 1/2 phi_r (phi_r^T dM/dp phi_r).

dK/dp, dM/dp of element i depend only on element i's section, so one rebuild of all elements
with every factor of a group moved by +-h gives all of that group's element derivatives
(central difference, exact for the linear Euler-Bernoulli parts).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from ema.shapes.mac import mac
from updating.correlate.measured import MeasuredModes, dofs_at
from updating.correlate.pairing import align_signs, paired_elastic
from updating.lsq import covariance
from updating.model.assembly import BatModel
from updating.model.modes import model_modes
from updating.msso.factors import (
    GROUP_PARTS,
    ElementFactors,
    apply_factors,
    factors_from_vector,
)

FD_STEP = 1e-5


@dataclass(frozen=True)
class RefineResult:
    """Refined factors, fit quality and the linearised standard deviation of each factor."""

    factors: ElementFactors
    std: ElementFactors
    n_iter: int
    converged: bool
    cost: float
    freq_error_rel: np.ndarray  # (m,) f_model / f_test - 1
    shape_error_rel: np.ndarray  # (m,) ||c phi_a - psi|| / ||psi||
    mac: np.ndarray
    jac_rank: int
    scales: np.ndarray  # (m,) per-mode shape scale c_r (ones if mass-normalised)
    chi2_data: float  # weighted data misfit sum r^2 (frequencies and shapes)
    n_data: int
    prior_sigma: float | None


def _element_derivatives(model: BatModel, f: ElementFactors, group: str):
    """(dK, dM) of every element w.r.t. its own factor of ``group`` (e, 4, 4) each."""
    out = []
    for sgn in (1.0, -1.0):
        parts = {p: v.copy() for p, v in zip(("bend", "shear", "trans", "rot"), f.as_tuple(),
                                               strict=True)}
        for p in GROUP_PARTS[group]:
            parts[p] = parts[p] + sgn * FD_STEP
        pm = apply_factors(model, ElementFactors(parts["bend"], parts["shear"], parts["trans"],
                                                 parts["rot"])).parts
        out.append((pm.k_bend + pm.k_shear, pm.m_trans + pm.m_rot))
    return ((out[0][0] - out[1][0]) / (2 * FD_STEP), (out[0][1] - out[1][1]) / (2 * FD_STEP))


def _evaluate(model, test, y, groups, n_rigid, scales, want_jac, w):
    e = model.n_elements
    f = factors_from_vector(y, groups, e)
    mdl = apply_factors(model, f)
    modes = model_modes(mdl)
    lam_all, Phi = modes.omega2, modes.shapes
    dofs_a = dofs_at(model, test.x_m)
    idx = paired_elastic(Phi, test.shapes, dofs_a, n_rigid)
    lam = lam_all[idx]
    phi_a = align_signs(test.shapes, Phi[np.ix_(dofs_a, idx)])
    Phi[:, idx] = Phi[:, idx] * np.sign(np.sum(phi_a * Phi[np.ix_(dofs_a, idx)], axis=0))
    lam_t = test.omega2
    psi = test.shapes
    rms = np.sqrt(np.mean(psi**2, axis=0))
    r_f = (lam / lam_t - 1) * w["f"]
    r_s = ((scales * phi_a - psi) / rms * w["s"]).ravel(order="F")
    r = np.concatenate([r_f, r_s, w["G"] @ y + w["g0"], w["L"] @ y])
    if not want_jac:
        return r, (lam, phi_a, f)
    m, a = idx.size, dofs_a.size
    np_ = len(groups) * e
    J_f = np.zeros((m, np_))
    J_s = np.zeros((a * m, np_))
    dofs = mdl.dofs
    Phi_a = Phi[dofs_a]
    for k, g in enumerate(groups):
        dK, dM = _element_derivatives(model, f, g)
        cols = slice(k * e, (k + 1) * e)
        for j, mode in enumerate(idx):
            P = Phi[dofs, mode]  # (e, 4)
            G = dK - lam[j] * dM
            J_f[j, cols] = np.einsum("ea,eab,eb->e", P, G, P) / lam_t[j] * w["f"]
            v = np.einsum("eab,eb->ea", G, P)
            coef = np.einsum("eas,ea->se", Phi[dofs], v)  # (n, e)
            gap = lam[j] - lam_all
            gap[mode] = np.inf
            coef /= gap[:, None]
            coef[mode] = -0.5 * np.einsum("ea,eab,eb->e", P, dM, P)
            dphi = Phi_a @ coef  # (a, e)
            J_s[j * a:(j + 1) * a, cols] = dphi * scales[j] / rms[j] * w["s"]
    J = np.vstack([J_f, J_s, w["G"], w["L"]])
    return r, J, (lam, phi_a, f)


def mass_rows(model: BatModel, groups: tuple[str, ...], weighed_mass_kg: float | None,
              mass_sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Build the weighed-mass residual (m0 + sum_i alpha_i m_i - m_w) / (sigma m_w) as (G, g0)."""
    p = model.n_elements * len(groups)
    if weighed_mass_kg is None:
        return np.zeros((0, p)), np.zeros(0)
    s = model.samples
    m_el = np.bincount(s.elem, s.weight_m * s.props.rhoa, model.n_elements)
    G = np.concatenate([m_el if g in ("m", "trans") else np.zeros_like(m_el) for g in groups])
    scale = 1.0 / (mass_sigma * weighed_mass_kg)
    return G[None, :] * scale, np.array([(m_el.sum() - weighed_mass_kg) * scale])


def prior_matrix(n_elements: int, n_groups: int, prior_sigma: float | None) -> np.ndarray:
    """Build the prior's rows.

    First differences of each group's factors along the bat over sigma (a smooth or
    piecewise-uniform change is cheap, a lone spike is not) and the factors themselves over
    10 sigma; no rows without a prior.
    """
    p = n_elements * n_groups
    if prior_sigma is None:
        return np.zeros((0, p))
    D = np.diff(np.eye(n_elements), axis=0)
    L = np.vstack([np.kron(np.eye(n_groups), D), 0.1 * np.eye(p)])
    return L / prior_sigma


def _with_scale_columns(J, phi_a, psi, w):
    """Append to J the columns d r / d c_r of the per-mode scales.

    They are non-zero only in the shape rows (block structure), zero in the frequency, mass
    and prior rows.
    """
    a, m = phi_a.shape
    rms = np.sqrt(np.mean(psi**2, axis=0))
    J_c = np.zeros((a * m, m))
    for j in range(m):
        J_c[j * a:(j + 1) * a, j] = phi_a[:, j] / rms[j] * w["s"]
    n_after = w["G"].shape[0] + w["L"].shape[0]
    return np.hstack([J, np.vstack([np.zeros((m, m)), J_c, np.zeros((n_after, m))])])


AUTO_PRIORS = (0.01, 0.1, 1.0, None)

PriorSigma = float | Literal["auto"] | None
"""The smoothness prior's standard deviation, "auto" (the discrepancy principle) or None."""


def check_prior_sigma(prior_sigma: PriorSigma) -> None:
    """ValueError unless ``prior_sigma`` is "auto", a number > 0 or None."""
    if prior_sigma is None or prior_sigma == "auto":
        return
    if not isinstance(prior_sigma, (int, float)) or not prior_sigma > 0:
        raise ValueError(f"unknown prior_sigma {prior_sigma!r} (auto, a number > 0 or None)")


def refine(
    model: BatModel, test: MeasuredModes, seed: ElementFactors, groups: tuple[str, ...], *,
    mass_normalised: bool = True, freq_sigma: float = 5e-4, shape_sigma: float = 1e-2,
    prior_sigma: PriorSigma = "auto", weighed_mass_kg: float | None = None,
    mass_sigma: float = 1e-3, n_rigid: int = 2, max_iter: int = 60, tol: float = 1e-12,
    lower: float = -0.95,
) -> RefineResult:
    """Levenberg-Marquardt fit of the element factors of ``groups`` to frequencies and shapes.

    Parameters
    ----------
    model : BatModel
        Reference model; its nodes include the test points ``test.x_m``.
    test : MeasuredModes
        Measured elastic modes at mesh nodes.
    seed : ElementFactors
        Start (usually the MSSO pass's factors).
    groups : tuple of str
        Parameter groups fitted (``factors.choose_groups``).
    mass_normalised : bool
        Whether the test shapes are scaled to unit modal mass. If not, each mode gets a free
        scale c_r; a uniform factor on all of K and M is then unobservable and
        ``weighed_mass_kg`` should be given.
    freq_sigma, shape_sigma : float
        Relative standard deviation of the measured frequencies, and of a shape entry
        relative to its mode's RMS: the residuals' weights.
    prior_sigma : float, "auto" or None
        Standard deviation of the smoothness prior (``prior_matrix``); None for none;
        "auto": Morozov's discrepancy principle by continuation, fits with the prior loosened
        step by step (``AUTO_PRIORS``, each warm-started) until the data chi^2 falls to the
        number of data (what the noise alone leaves); exact data run through to no prior.
    weighed_mass_kg, mass_sigma : float
        The bat's weighed mass and its relative standard deviation: adds the residual
        (m(y) - m_w) / (sigma m_w).
    n_rigid : int
        Lowest model modes never paired (rigid-body or suspension modes).
    max_iter, tol : int, float
        Iteration cap and relative cost decrease that stops the iteration.
    lower : float
        No factor goes below this (steps are shortened to stay above it).

    Returns
    -------
    RefineResult
        Factors, their linearised standard deviations (``updating.lsq.covariance``),
        iterations, fit quality, MACs, Jacobian rank, per-mode scales, data chi^2.

    References
    ----------
    Fox, R. L., Kapoor, M. P. (1968), Rates of change of eigenvalues and eigenvectors, AIAA J.
    6(12). Morozov, V. A. (1966), On the solution of functional equations by the method of
    regularization, Soviet Math. Dokl. 7.
    """
    check_prior_sigma(prior_sigma)
    kw = {"mass_normalised": mass_normalised, "freq_sigma": freq_sigma,
          "shape_sigma": shape_sigma, "n_rigid": n_rigid, "max_iter": max_iter, "tol": tol,
          "lower": lower, "weighed_mass_kg": weighed_mass_kg, "mass_sigma": mass_sigma}
    if prior_sigma != "auto":
        return _levenberg_marquardt(model, test, seed, groups, prior_sigma=prior_sigma, **kw)
    f = seed
    for ps in AUTO_PRIORS:
        rr = _levenberg_marquardt(model, test, f, groups, prior_sigma=ps, **kw)
        if rr.chi2_data <= rr.n_data:
            break
        f = rr.factors
    return rr


def _levenberg_marquardt(
    model: BatModel, test: MeasuredModes, seed: ElementFactors, groups: tuple[str, ...], *,
    mass_normalised: bool, freq_sigma: float, shape_sigma: float, prior_sigma: float | None,
    weighed_mass_kg: float | None, mass_sigma: float, n_rigid: int, max_iter: int, tol: float,
    lower: float,
) -> RefineResult:
    e = model.n_elements
    w = {"f": 1.0 / (2 * freq_sigma), "s": 1.0 / shape_sigma,
         "L": prior_matrix(e, len(groups), prior_sigma)}
    w["G"], w["g0"] = mass_rows(model, groups, weighed_mass_kg, mass_sigma)
    y = seed.vector(groups).copy()
    m = test.shapes.shape[1]
    scales = np.ones(m)
    if not mass_normalised:
        _, (_, phi_a, _) = _evaluate(model, test, y, groups, n_rigid, scales, False, w)
        scales = np.sum(phi_a * test.shapes, axis=0) / np.sum(phi_a**2, axis=0)
    mu, converged, it = 1e-3, False, 0
    r, J, (lam, phi_a, f) = _evaluate(model, test, y, groups, n_rigid, scales, True, w)
    if not mass_normalised:
        J = _with_scale_columns(J, phi_a, test.shapes, w)
    cost = 0.5 * float(r @ r)
    for it in range(1, max_iter + 1):  # noqa: B007
        A = J.T @ J
        g = J.T @ r
        D = np.maximum(np.diag(A), 1e-12 * np.max(np.diag(A)))
        accepted = False
        while mu < 1e12:
            step = -np.linalg.solve(A + mu * np.diag(D), g)
            dy = step[:y.size]
            limit = np.where(dy < 0, (y - lower) / np.maximum(-dy, 1e-300), np.inf)
            t = min(1.0, 0.9 * float(np.min(limit)))
            y_new = y + t * dy
            s_new = scales + t * step[y.size:] if not mass_normalised else scales
            r_new, _ = _evaluate(model, test, y_new, groups, n_rigid, s_new, False, w)
            c_new = 0.5 * float(r_new @ r_new)
            if c_new <= cost:
                accepted = True
                break
            mu *= 4.0
        if not accepted:
            converged = True
            break
        rel = (cost - c_new) / max(cost, 1e-300)
        small = np.max(np.abs(t * step)) < 1e-10
        y, scales, cost = y_new, s_new, c_new
        mu = max(mu / 3.0, 1e-9)
        r, J, (lam, phi_a, f) = _evaluate(model, test, y, groups, n_rigid, scales, True, w)
        if not mass_normalised:
            J = _with_scale_columns(J, phi_a, test.shapes, w)
        if rel < tol or small:
            converged = True
            break
    sv = np.linalg.svd(J[:J.shape[0] - w["L"].shape[0]], compute_uv=False)
    rank = int(np.sum(sv > 1e-8 * sv[0]))
    cov_diag = np.diag(covariance(J, rcond=1e-12))[:y.size]
    std = factors_from_vector(np.sqrt(np.clip(cov_diag, 0, None)), groups, e)
    psi = test.shapes
    shape_err = np.linalg.norm(scales * phi_a - psi, axis=0) / np.linalg.norm(psi, axis=0)
    macs = np.diag(mac(phi_a, psi))
    chi2 = 2 * cost - float(np.sum((w["L"] @ y) ** 2))
    n_data = m + test.shapes.size - (0 if mass_normalised else m) + w["G"].shape[0]
    return RefineResult(f, std, it, converged, cost, np.sqrt(lam / test.omega2) - 1, shape_err,
                        macs, rank, scales, chi2, n_data, prior_sigma)
