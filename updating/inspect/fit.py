"""Nonlinear least-squares fit of the change model to a re-test, relative to the baseline.

Data (paired modes r, test points j): the measured changes

    y_f[r]    = ln(f_retest[r] / f_baseline[r])
    y_psi[j,r] = psi_retest[j,r] - psi_baseline[j,r]        (mass-normalised shapes)

are matched by the model's changes from the reference, ln(f(theta)/f(0)) and
phi(theta) - phi(0), so that what the calibrated reference gets wrong (and the test's own
bias) largely cancels. Residuals are weighted by their standard deviations: sigma_f from the
modal fit's frequency uncertainties, sigma_psi = sigma_rel * rms-shape of the mode (one
relative shape-noise level estimated from the residuals). Parameters:

    null:  x = [100 (s_E - 1), 100 (s_rho - 1), sensor shift (in)]
    core:  x = null + [core depth from the barrel end (in), p = r b, q = (R - r) b]

with b = (d / 1 in)^2 for core diameter d, fill density ratio r in [0, R]: the box p, q >= 0
is exactly the cone of physical cores, b = (p + q) / R and r = R p / (p + q). The core's
mass change (r - 1) b and its stiffness change (shear through the section's area and
Cowper's coefficient ~ b, bending ~ b^2) are nearly linear in (p, q), so the model has a
non-vanishing gradient at "no core" and no flat regions.

The core fit starts from the best depths of a linearised scan (the residual projected on
the null model's Jacobian and on the responses to a stiffness-only and a mass-only core at
each depth), which avoids the local minima of the depth.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from updating.inspect.model import ChangeParams
from updating.lsq import solve_bounded
from updating.model.profile import Profile
from updating.model.sections import Core
from updating.model.units import IN_TO_M

NULL_LOWER = np.array([-15.0, -10.0, -0.5])
NULL_UPPER = np.array([15.0, 10.0, 0.5])
R_MAX = 6.0  # densest fill considered, relative to the wood
CORE_LOWER = np.array([0.0, 0.0, 0.0])  # depth lower bound is set from the plug
CORE_UPPER = np.array([15.0, 2.6 * R_MAX, 2.6 * R_MAX])
MIN_B = 1e-4  # (0.01 in)^2: the smallest core diameter the model builds
MAX_NFEV_START, MAX_NFEV_CORE = 15, 30
"""Caps on core-fit iterations (each start, final refinement): a real core converges in
fewer; without one the depth is unidentifiable and the optimiser would wander (an
unconverged H1 fit only lowers F)."""


@dataclass(frozen=True)
class Differences:
    """Measured changes between the tests, their weights and the reference's modes.

    Attributes:
        model_index: (m,) index of each pair's mode among the predictor's modes.
        dlnf: (m,) ln(f_retest / f_baseline); sigma_lnf: (m,) its standard deviation.
        dpsi: (n_points, m) retest minus baseline shapes (signs aligned).
        psi_scale: (m,) sqrt(rms_baseline^2 + rms_retest^2) of each mode's shape entries.
        f0: (m,) reference model frequencies, Hz; phi0: (n_points, m) its shapes, aligned.
    """

    model_index: np.ndarray
    dlnf: np.ndarray
    sigma_lnf: np.ndarray
    dpsi: np.ndarray
    psi_scale: np.ndarray
    f0: np.ndarray
    phi0: np.ndarray

    @property
    def n_freq(self) -> int:
        return self.dlnf.size

    @property
    def n_data(self) -> int:
        return self.dlnf.size + self.dpsi.size


@dataclass(frozen=True)
class ChangeFit:
    """A least-squares solution: parameters, weighted residual, Jacobian (in x units)."""

    x: np.ndarray
    params: ChangeParams
    residual: np.ndarray
    jac: np.ndarray
    n_freq: int

    @property
    def rss(self) -> float:
        return float(self.residual @ self.residual)

    @property
    def rss_shapes(self) -> float:
        r = self.residual[self.n_freq:]
        return float(r @ r)


@dataclass(frozen=True)
class ParamSpace:
    """How a parameter vector becomes a state of this bat (``ChangeParams``).

    ``sensor_mount_m`` is the nominal move of the accelerometer between the tests (the
    difference of the labelled sensor points); the fitted shift is added to it.
    """

    profile: Profile
    plug_m: float
    fill_modulus_ratio: float = 0.0
    sensor_mount_m: float = 0.0

    def lower(self) -> np.ndarray:
        lo = CORE_LOWER.copy()
        lo[0] = self.plug_m / IN_TO_M + 0.5
        return np.concatenate([NULL_LOWER, lo])

    def upper(self) -> np.ndarray:
        return np.concatenate([NULL_UPPER, CORE_UPPER])

    def core(self, depth_in: float, p: float, q: float) -> Core:
        """The core of x[3:6]; diameter clipped to 90 % of the thinnest outer diameter it
        spans."""
        L = self.profile.length_m
        depth = min(depth_in * IN_TO_M, 0.95 * L)
        xs = np.linspace(L - depth, L - self.plug_m, 25)
        b = max((p + q) / R_MAX, MIN_B)
        r = R_MAX * p / (p + q) if p + q > 0 else 1.0
        d = min(np.sqrt(b) * IN_TO_M, 0.9 * float(np.min(self.profile.diameter_at(xs))))
        return Core(d, depth, r, self.fill_modulus_ratio, self.plug_m)

    def reading(self, x: np.ndarray, cov: np.ndarray) -> dict:
        """Core start (m from the knob end), diameter (m), fill ratio and their standard
        uncertainties from the covariance of x (first-order propagation)."""
        _, p, q = x[3:6]
        s = max(p + q, R_MAX * MIN_B)
        b = s / R_MAX
        dd = IN_TO_M / (2 * np.sqrt(b)) / R_MAX
        grads = {"region_start_m": np.array([-IN_TO_M, 0.0, 0.0]),
                 "core_diameter_m": np.array([0.0, dd, dd]),
                 "fill_density_ratio": R_MAX * np.array([0.0, q, -p]) / s**2}
        c = cov[3:6, 3:6]
        sd = {k: float(np.sqrt(max(g @ c @ g, 0.0))) for k, g in grads.items()}
        return {"core": self.core(*x[3:6]), "sd": sd}

    def params(self, x: np.ndarray) -> ChangeParams:
        core = None if x.size == 3 else self.core(*x[3:6])
        return ChangeParams(1 + x[0] / 100, 1 + x[1] / 100,
                            self.sensor_mount_m + x[2] * IN_TO_M, core)

    def to_x(self, depth_in: float, b: float, r: float) -> np.ndarray:
        """Core part of x for depth (in), b = (d / 1 in)^2 and fill ratio r."""
        return np.array([depth_in, r * b, (R_MAX - r) * b])


def residual_function(
    predict: Callable, diff: Differences, space: ParamSpace, sigma_rel: float,
) -> Callable[[np.ndarray], np.ndarray]:
    """x -> weighted residual (measured minus predicted change), length n_data."""
    def fun(x: np.ndarray) -> np.ndarray:
        f, phi = predict(space.params(np.asarray(x, dtype=float)))
        f, phi = f[diff.model_index], phi[:, diff.model_index]
        phi = phi * np.sign(np.einsum("ij,ij->j", phi, diff.phi0))
        rf = (diff.dlnf - np.log(f / diff.f0)) / diff.sigma_lnf
        rs = (diff.dpsi - (phi - diff.phi0)) / (sigma_rel * diff.psi_scale)
        return np.concatenate([rf, rs.ravel()])

    return fun


def fit_bounded(fun: Callable, x0: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                space: ParamSpace, n_freq: int, max_nfev: int | None = None) -> ChangeFit:
    """Bounded Gauss-Newton (trust-region reflective, updating.lsq.solve_bounded) from x0."""
    res = solve_bounded(fun, x0, lower, upper, diff_step=1e-6, x_scale=1.0, ftol=1e-6,
                        xtol=1e-6, max_nfev=max_nfev)
    return ChangeFit(res.x, space.params(res.x), res.residual, res.jac, n_freq)


def fit_null(predict, diff: Differences, space: ParamSpace, sigma_rel: float,
             x0: np.ndarray | None = None) -> ChangeFit:
    """Moisture and sensor shift only."""
    fun = residual_function(predict, diff, space, sigma_rel)
    x0 = np.zeros(3) if x0 is None else x0
    return fit_bounded(fun, x0, NULL_LOWER, NULL_UPPER, space, diff.n_freq)


def depth_scan(
    predict, diff: Differences, space: ParamSpace, sigma_rel: float, null: ChangeFit,
    depths_in: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Linearised scan: for each depth, residual norm and seed x (6,) for the core fit.

    The change in residual from a 1 in core with density-neutral fill (b = 1, r = 1:
    stiffness only), and from making that fill massless (r = 0: mass only), are combined
    with the null Jacobian; the least-squares coefficients c_s, c_m seed b = c_s^0.8
    (stiffness ~ b^1.25) and r = 1 - c_m / b (mass change (r - 1) b = -c_m).
    """
    fun = residual_function(predict, diff, space, sigma_rel)
    r0 = null.residual
    norms, seeds = [], []
    for depth in depths_in:
        r_stiff = fun(np.concatenate([null.x, space.to_x(depth, 1.0, 1.0)]))
        r_mass = fun(np.concatenate([null.x, space.to_x(depth, 1.0, 0.0)]))
        A = np.column_stack([null.jac, r_stiff - r0, r_mass - r_stiff])
        coef, *_ = np.linalg.lstsq(A, -r0, rcond=None)
        norms.append(float(np.linalg.norm(r0 + A @ coef)))
        c_s, c_m = coef[3], coef[4]
        b = float(np.clip(max(c_s, 0.0) ** 0.8, 0.01, 2.2))
        r = float(np.clip(1.0 - c_m / b, 0.05, R_MAX - 0.05))
        seeds.append(np.concatenate([null.x + coef[:3], space.to_x(depth, b, r)]))
    return np.array(norms), np.array(seeds)


def fit_core(
    predict, diff: Differences, space: ParamSpace, sigma_rel: float, null: ChangeFit,
    depths_in: np.ndarray, n_starts: int = 2, min_separation_in: float = 2.0,
    x0: np.ndarray | None = None,
) -> tuple[ChangeFit, dict]:
    """Moisture, sensor shift and a core; multi-start from the depth scan (or from x0)."""
    fun = residual_function(predict, diff, space, sigma_rel)
    lo, hi = space.lower(), space.upper()
    if x0 is not None:
        return (fit_bounded(fun, x0, lo, hi, space, diff.n_freq, MAX_NFEV_CORE),
                {"starts_in": [float(x0[3])]})
    norms, seeds = depth_scan(predict, diff, space, sigma_rel, null, depths_in)
    starts: list[np.ndarray] = []
    for i in np.argsort(norms):
        if all(abs(seeds[i][3] - s[3]) >= min_separation_in for s in starts):
            starts.append(seeds[i])
        if len(starts) == n_starts:
            break
    fits = [fit_bounded(fun, s, lo, hi, space, diff.n_freq, MAX_NFEV_START) for s in starts]
    best = min(fits, key=lambda f: f.rss)
    info = {"scan_depth_in": [float(d) for d in depths_in],
            "scan_norm": [float(n) for n in norms],
            "starts_in": [float(s[3]) for s in starts],
            "start_rss": [f.rss for f in fits]}
    return best, info


SHAPE_NOISE_FLOOR = 1e-3
"""Lowest relative shape noise used: the model error of the predicted shape changes (caliper
noise of the profile, mesh, calibration) is of this order, so with cleaner data than this the
F test would call that model error an alteration (measured: nearly noise-free unaltered bats
with a diagnose-calibrated reference gave F = 14 without the floor), and two identical tests
would have zero residual."""


def shape_noise(fit: ChangeFit, diff: Differences, sigma_rel: float, n_params: int) -> float:
    """Relative shape noise re-estimated from a fit's shape residual:

        sigma_rel^2 = sum(r_psi^2) sigma_old^2 / (n_psi - p n_psi / n)

    (the parameters' degrees of freedom shared in proportion to the data), not below
    ``SHAPE_NOISE_FLOOR``."""
    n_psi = diff.dpsi.size
    dof = n_psi - n_params * n_psi / diff.n_data
    return max(float(sigma_rel * np.sqrt(fit.rss_shapes / dof)), SHAPE_NOISE_FLOOR)
