"""The MSSO element map of a re-test: *where* mass and stiffness changed (../docs/inspection.md).

Independent of the physical core fit. What every bat does between two tests is removed from
the reference first, so the map shows only the local change:

1. the calibrated reference, meshed with nodes at the test points, with the accelerometer
   where ``baseline_sensor_offset`` put it at the baseline, is updated element by element to
   the **baseline** test (SEREP + MSSO + Levenberg-Marquardt, ``update_elements``): the
   calibration's residual errors (E, E/G, bungees, sensor mass) are absorbed here;
2. that model gets the accepted fit's uniform drift scales (EI and kGA by s_E, rhoA and rhoI
   by s_rho) and the accelerometer where that fit put it (the moisture+core fit when the bat
   is altered: the moisture-only fit's scales absorb part of a core);
3. the re-test is updated against it: K_I = K + sum beta_i k_bend_i,
   M_I = M + sum alpha_i m_trans_i (bending and translational factors; ``update_elements``
   with the re-test's paired modes at the measured translational DOFs, weighted by the noise
   levels the inspection estimated, and a fixed smoothness prior ``prior_sigma``).

Before each update the measured shapes psi are freed of the roving-hammer fitter's
driving-point factor (``inspect.model.driving_point_scale``): psi / sqrt(phi(x_s) / phi(x_d)),
with phi the paired modes of the model being updated, x_s the accelerometer's position in that
model and x_d the test's labelled driving point. The sensor is re-mounted between the tests,
so the two factors differ per mode and would otherwise show up as element changes.

Region: ``core_reading.changed_region`` (contiguous run of significant factors around the
peak, z = hypot(beta / s_beta, alpha / s_alpha) > 3 with s the refinement's linearised
standard deviations; on unaltered fleet bats the peak z stayed at or below 2.0,
docs/inspection.md).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from updating.correlate.measured import MeasuredModes, dofs_at
from updating.correlate.pairing import paired_elastic
from updating.inspect.model import driving_point_scale
from updating.model.assembly import BatModel, displacement_at
from updating.model.modes import model_modes
from updating.model.profile import Profile
from updating.model.reference import BatReference
from updating.msso.core_reading import changed_region
from updating.msso.factors import Mass, Stiffness, apply_factors, choose_groups, zero_factors
from updating.msso.iterate import refine
from updating.msso.update import ElementUpdate, update_elements

PRIOR_SIGMA = 0.03
"""Smoothness prior of the map's refinement (first differences of neighbouring factors):
measured on the virtual fleet, 0.01 smears a cork's mass change out of the region, weaker
priors let 1-2 % shape noise through (docs/inspection.md)."""
RESTART_CHI2 = 3.0
"""An MSSO-seeded refinement with data chi^2 above this many times the number of data is
redone from no change (the one pass can land on a mode-swapped model)."""


@dataclass(frozen=True)
class MssoMap:
    """Per-element factors of the re-test.

    Per-element factors of the re-test relative to the moisture-corrected, baseline-updated
    reference (SI positions; factors dimensionless).

    Attributes
    ----------
    x0_m, x1_m
        (e,) element ends.
    alpha, beta
        (e,) translational-mass and bending factors.
    alpha_std, beta_std
        Their linearised standard deviations.
    region_m
        (start, end) of the contiguous significant run, or None.
    peak_z
        Its z.
    rank
        Rank of MSSO's one-pass system.
    chi2, n_data
        Data misfit of the refinement.
    baseline_chi2
        The same for the baseline update (step 1).
    groups
        Parameter groups.
    time_s
        Wall time of the three steps.
    """

    x0_m: np.ndarray
    x1_m: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    alpha_std: np.ndarray
    beta_std: np.ndarray
    region_m: tuple[float, float] | None
    peak_z: float
    rank: int
    chi2: float
    n_data: int
    baseline_chi2: float
    groups: tuple[str, ...]
    time_s: float

    def to_dict(self) -> dict:
        """Write the map as a dict."""
        return {"alpha": self.alpha.tolist(), "beta": self.beta.tolist(),
                "alpha_std": self.alpha_std.tolist(), "beta_std": self.beta_std.tolist(),
                "region_m": None if self.region_m is None else list(self.region_m),
                "peak_z": self.peak_z, "rank": self.rank, "chi2": self.chi2,
                "n_data": self.n_data, "baseline_chi2": self.baseline_chi2,
                "groups": list(self.groups), "time_s": self.time_s}


def _without_driving_point_factor(
    model: BatModel, modes: MeasuredModes, dofs, sensor_x_m: float,
) -> MeasuredModes:
    """Rescale a roving-hammer test's shapes.

    ``modes`` with each shape divided by sqrt(phi(x_s) / phi(x_d))
    (``driving_point_scale``): phi the model's modes paired with them, x_s = ``sensor_x_m``
    where the accelerometer sat, x_d = ``modes.sensor_x_m`` the labelled driving point.
    """
    Phi = model_modes(model).shapes
    idx = paired_elastic(Phi, modes.shapes, dofs, 2)
    phi_s, phi_d = displacement_at(model, Phi[:, idx], [sensor_x_m, modes.sensor_x_m])
    return replace(modes, shapes=modes.shapes / driving_point_scale(phi_s, phi_d))


def _update(model, modes: MeasuredModes, dofs, kw) -> ElementUpdate:
    """update_elements, redone from no change when the MSSO seed led the refinement astray."""
    u = update_elements(model, modes.freq_hz, modes.shapes, dofs, **kw)
    rr = u.refinement
    if rr.chi2_data <= RESTART_CHI2 * rr.n_data:
        return u
    groups = choose_groups(model, kw["stiffness"], kw["mass"])
    try:
        r0 = refine(model, modes, zero_factors(model.n_elements), groups,
                    freq_sigma=kw["freq_sigma"], shape_sigma=kw["shape_sigma"],
                    prior_sigma=kw["prior_sigma"], mass_normalised=kw["mass_normalised"])
    except ValueError:  # modes no longer pair from that start either
        return u
    return replace(u, factors=r0.factors, refinement=r0) if r0.chi2_data < rr.chi2_data else u


def msso_map(
    profile: Profile, reference: BatReference, baseline: MeasuredModes, retest: MeasuredModes,
    *, stiffness_scale: float, density_scale: float, sensor_shift_m: float,
    baseline_sensor_offset_m: float = 0.0, shape_sigma: float, freq_sigma: float,
    prior_sigma: float = PRIOR_SIGMA,
    stiffness: Stiffness = "bend", mass: Mass = "trans", mass_normalised: bool = True,
) -> MssoMap:
    """Map the re-test's change element by element (module docstring).

    Parameters
    ----------
    profile, reference
        The bat and its calibrated reference.
    baseline, retest
        Paired elastic modes (mass-normalised shapes at the test points).
    stiffness_scale, density_scale, sensor_shift_m
        The accepted fit's drift (the shift relative to the baseline's sensor position, as
        ``ChangeParams.sensor_shift_m``).
    baseline_sensor_offset_m
        The baseline's sensor position relative to ``reference.sensor_x_m``
        (``updating.inspect.model.baseline_sensor_offset``).
    shape_sigma
        Shape noise relative to each mode's RMS.
    freq_sigma
        Relative frequency noise of one test.
    prior_sigma
        Smoothness prior of the refinement (``updating.msso.iterate.prior_matrix``).
    stiffness, mass
        ``update_elements`` parameterisation ("bend"/"trans" by default).

    Raises
    ------
    ValueError
        When the test modes cannot be paired with the model's.
    """
    t0 = time.perf_counter()
    points = np.asarray(baseline.x_m, dtype=float)
    kw = {"stiffness": stiffness, "mass": mass, "freq_sigma": freq_sigma,
          "shape_sigma": shape_sigma, "prior_sigma": prior_sigma,
          "mass_normalised": mass_normalised}
    L = profile.length_m
    x_base = float(np.clip(reference.sensor_x_m + baseline_sensor_offset_m, 0.0, L))
    x_re = float(np.clip(x_base + sensor_shift_m, 0.0, L))
    model0 = replace(reference, sensor_x_m=x_base).build(profile, points)
    dofs = dofs_at(model0, points)
    ub = _update(model0, _without_driving_point_factor(model0, baseline, dofs, x_base),
                 dofs, kw)
    moist = replace(reference, E_pa=reference.E_pa * stiffness_scale,
                    rho_kg_m3=reference.rho_kg_m3 * density_scale, sensor_x_m=x_re)
    model = apply_factors(moist.build(profile, points), ub.factors)
    u = _update(model, _without_driving_point_factor(model, retest, dofs, x_re), dofs, kw)
    alpha, beta = u.factors.alpha_trans, u.factors.beta_bend
    s_a, s_b = u.refinement.std.alpha_trans, u.refinement.std.beta_bend
    el, z = changed_region(beta, alpha, s_b, s_a)
    x = model.node_x_m
    region = None if el.size == 0 else (float(x[el[0]]), float(x[el[-1] + 1]))
    return MssoMap(x[:-1].copy(), x[1:].copy(), alpha, beta, s_a, s_b, region, z, u.rank,
                   float(u.refinement.chi2_data), int(u.refinement.n_data),
                   float(ub.refinement.chi2_data), u.groups, time.perf_counter() - t0)
