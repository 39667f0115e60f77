"""Element updating from a re-test: pairing, SEREP, MSSO, iterated expansion, refinement.

``update_elements`` is the entry point for later stages: a reference model, measured natural
frequencies and real shapes at translational DOFs in, per-element relative changes out (with
their scatter when the test modes are resampled with their noise).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from updating.correlate.measured import MeasuredModes, dofs_at, with_noise
from updating.correlate.pairing import align_signs, pseudo_orthogonality
from updating.correlate.serep import paired_serep
from updating.model.assembly import BatModel, assemble
from updating.model.modes import model_modes
from updating.msso.expansion import expansion_pass
from updating.msso.factors import ElementFactors, Mass, Stiffness, choose_groups, zero_factors
from updating.msso.iterate import PriorSigma, RefineResult, check_prior_sigma, refine
from updating.msso.regularisation import Regularisation, check_regularisation
from updating.msso.skyline import MssoResult


@dataclass(frozen=True)
class ElementUpdate:
    """Result of updating: final and one-pass factors, diagnostics, resampled scatter.

    ``std`` is the standard deviation over ``draws`` (n_resample re-runs with the test modes
    perturbed by their noise), None without resampling (the refinement's linearised estimate
    is in ``refinement.std``). ``draws`` has shape (n_draws, 4, e) in the order bend, shear,
    trans, rot.
    """

    factors: ElementFactors
    one_pass: ElementFactors
    groups: tuple[str, ...]
    msso: MssoResult
    refinement: RefineResult | None
    serep_cond: float
    poc_max_offdiag: float
    n_expansions: int
    std: ElementFactors | None = None
    draws: np.ndarray | None = None

    @property
    def alpha_trans(self) -> np.ndarray:
        """Return the translational mass factors."""
        return self.factors.alpha_trans

    @property
    def alpha_rot(self) -> np.ndarray:
        """Return the rotary inertia factors."""
        return self.factors.alpha_rot

    @property
    def beta_bend(self) -> np.ndarray:
        """Return the bending stiffness factors."""
        return self.factors.beta_bend

    @property
    def beta_shear(self) -> np.ndarray:
        """Return the shear stiffness factors."""
        return self.factors.beta_shear

    @property
    def rank(self) -> int:
        """Return the rank of the MSSO system."""
        return self.msso.rank


def mass_normalise(model: BatModel, test: MeasuredModes, n_rigid: int = 2) -> MeasuredModes:
    """Scale unscaled test shapes to unit modal mass with the SEREP-reduced reference mass.

    psi_r / sqrt(psi_r^T M_a psi_r), M_a = T^T M T.
    """
    Phi = model_modes(model).shapes
    dofs = dofs_at(model, test.x_m)
    _, T = paired_serep(Phi, test.shapes, dofs, n_rigid)
    Ma = T.reduce(assemble(model)[1])
    mm = np.einsum("ar,ab,br->r", test.shapes, Ma, test.shapes)
    return replace(test, shapes=test.shapes / np.sqrt(mm))


def _run(model, test, groups_kw, msso_kw, expansions, do_refine, mass_normalised, sigmas,
         prior_sigma, scaled: MeasuredModes | None = None):
    """Run the expansion passes and the refinement.

    ``scaled``: ``test`` already mass-normalised (``mass_normalise``, when the caller has it),
    else normalised here if need be.
    """
    refine_groups = choose_groups(model, groups_kw.pop("refine_stiffness"),
                                  groups_kw.pop("refine_mass"))
    n_rigid = 2
    if scaled is None:
        scaled = test if mass_normalised else mass_normalise(model, test, n_rigid)
    f, first, res, cond = zero_factors(model.n_elements), None, None, np.nan
    for _ in range(max(1, expansions)):
        f, res, c = expansion_pass(model, scaled, f, n_rigid, **groups_kw, **msso_kw)
        if first is None:
            first, cond = f, c
    rr = None
    if do_refine:
        rr = refine(model, test, f, refine_groups, mass_normalised=mass_normalised,
                    freq_sigma=sigmas[0], shape_sigma=sigmas[1], prior_sigma=prior_sigma,
                    weighed_mass_kg=msso_kw["weighed_mass_kg"])
        f = rr.factors
    return f, first, res, rr, cond


def _test_modes(model: BatModel, freq_hz, shapes_a, dofs_a) -> MeasuredModes:
    """Check the measured modes against the model and wrap them as ``MeasuredModes``.

    Raises ValueError when ``shapes_a`` is not (a, m) or ``dofs_a`` are not translational
    DOFs of ``model``.
    """
    freq_hz = np.asarray(freq_hz, dtype=float)
    shapes_a = np.asarray(shapes_a, dtype=float)
    dofs_a = np.asarray(dofs_a, dtype=int)
    m = freq_hz.size
    if shapes_a.ndim != 2 or shapes_a.shape != (dofs_a.size, m):
        raise ValueError(f"shapes_a must be (a={dofs_a.size}, m={m})")
    if np.any(dofs_a % 2) or np.any(dofs_a >= model.n_dof):
        raise ValueError("dofs_a must be translational DOFs of the model")
    return MeasuredModes(freq_hz, shapes_a, model.node_x_m[dofs_a // 2], np.zeros(m),
                         float("nan"))


def _scaling_check(model: BatModel, test: MeasuredModes, dofs_a: np.ndarray,
                   scaled: MeasuredModes, mass_normalised: bool) -> float:
    """Return the largest off-diagonal pseudo-orthogonality of the (scaled) test shapes.

    POC = psi^T M_a psi with M_a the SEREP-reduced reference mass; the shapes are sign-aligned
    with the reference when given mass-normalised, else taken as ``mass_normalise`` scaled
    them.
    """
    Phi = model_modes(model).shapes
    dofs_a = np.asarray(dofs_a, dtype=int)
    idx, T = paired_serep(Phi, test.shapes, dofs_a, 2)
    sa = (align_signs(Phi[np.ix_(dofs_a, idx)], test.shapes) if mass_normalised
          else scaled.shapes)
    return pseudo_orthogonality(sa, T.reduce(assemble(model)[1])).max_offdiag


def update_elements(
    model: BatModel, freq_hz, shapes_a, dofs_a, *, stiffness: Stiffness | None = "element",
    mass: Mass | None = "element", mass_normalised: bool = True, expansions: int = 1,
    refine_fit: bool = True, regularisation: Regularisation = "gcv",
    weights: dict | None = None, weighed_mass_kg: float | None = None,
    freq_sigma: float = 5e-4, shape_sigma: float = 1e-2, prior_sigma: PriorSigma = "auto",
    n_resample: int = 0, rng: np.random.Generator | None = None,
    msso_parts: tuple[Stiffness | None, Mass | None] | None = None,
) -> ElementUpdate:
    """Per-element mass and stiffness changes of a re-tested bat against its reference.

    Pairing, SEREP, MSSO (``expansions`` passes), then the Levenberg-Marquardt refinement
    seeded by MSSO, and optionally the scatter of the result under the test's noise.

    Parameters
    ----------
    model : BatModel
        Reference (calibrated) model whose nodes include the measured points.
    freq_hz : (m,) array
        Measured natural frequencies of elastic modes.
    shapes_a : (a, m) array
        Real shapes at ``dofs_a`` (translational DOFs, e.g. ``correlate.measured.dofs_at``),
        mass-normalised unless ``mass_normalised=False`` (then scaled by the reference mass
        for MSSO and fitted with a free scale per mode in the refinement).
    dofs_a : (a,) int array
        The measured translational DOFs.
    stiffness, mass : str or None
        Parameterisation: "element" (the paper's one beta and one alpha per element),
        "separate" (bending / shear and translational / rotary), "bend", "trans", or None.
    expansions : int
        SEREP + MSSO passes (1: the paper's single pass).
    refine_fit : bool
        Run the Levenberg-Marquardt refinement seeded by MSSO.
    regularisation : {"gcv", "lcurve"}, float or None
        MSSO's (``msso.regularisation.solve_regularised``).
    weights : dict, optional
        MSSO block weights.
    weighed_mass_kg : float, optional
        The bat's weighed mass (MSSO equation (4) and a refinement residual).
    freq_sigma, shape_sigma : float
        Noise of the frequencies (relative) and of the shape entries (relative to each
        mode's RMS): the refinement's weights and the resampling noise.
    prior_sigma : float, "auto" or None
        The refinement's smoothness prior (``msso.iterate.refine``).
    n_resample : int
        Re-runs with the test modes perturbed by that noise, giving ``std`` and ``draws``.
    rng : numpy Generator, optional
        Random numbers of the resampling.
    msso_parts : (str or None, str or None), optional
        (stiffness, mass) of the MSSO seed if it should differ from the refined
        parameterisation (e.g. ("element", "element") to seed a separable refinement).

    Returns
    -------
    ElementUpdate
        Final and one-pass factors, the MSSO and refinement results, SEREP condition,
        pseudo-orthogonality, resampled scatter.
    """
    test = _test_modes(model, freq_hz, shapes_a, dofs_a)
    choose_groups(model, stiffness, mass)  # the string options checked here, once
    seed_s, seed_m = (stiffness, mass) if msso_parts is None else msso_parts
    choose_groups(model, seed_s, seed_m)
    check_regularisation(regularisation)
    check_prior_sigma(prior_sigma)
    msso_kw = {"regularisation": regularisation, "weights": weights,
               "weighed_mass_kg": weighed_mass_kg}
    sig = (freq_sigma, shape_sigma)

    def groups_kw():
        return {"stiffness": seed_s, "mass": seed_m, "refine_stiffness": stiffness,
                "refine_mass": mass}

    def run_once(modes: MeasuredModes, scaled: MeasuredModes | None = None):
        return _run(model, modes, groups_kw(), msso_kw, expansions, refine_fit,
                    mass_normalised, sig, prior_sigma, scaled)

    scaled = test if mass_normalised else mass_normalise(model, test)  # once, used twice
    f, first, res, rr, cond = run_once(test, scaled)
    poc_max = _scaling_check(model, test, dofs_a, scaled, mass_normalised)
    std, draws = None, None
    if n_resample > 0:
        rng = np.random.default_rng() if rng is None else rng
        draws = np.stack([np.stack(run_once(with_noise(test, shape_sigma, freq_sigma, rng))[0]
                                   .as_tuple()) for _ in range(n_resample)])
        std = ElementFactors(*draws.std(axis=0, ddof=1))
    return ElementUpdate(f, first, choose_groups(model, stiffness, mass), res, rr, cond,
                         poc_max, max(1, expansions), std, draws)
