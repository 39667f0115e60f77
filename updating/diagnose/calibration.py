"""Least-squares fit of one member of the diagnosis model family to measured modes.

Residuals (dimensionless; frequencies are what the RMS error measures):

    e_r  = f_r(model) / f_r(measured) - 1                        paired elastic modes
    s_ir = (sigma_f / sigma_s) (y_ir - sign_r u_ir) / rms(y_r)    shape entries
    b_j  = (sigma_f / sigma_b) (f_j(model) / f_j(suspension) - 1)  suspension modes (if any)
    g_j  = (sigma_f / sigma_g) (G_j(model) - a_j)                 mass line (if measured)
    p    = (sigma_f / sigma_p) (m_s(model) - m_s(data sheet))     accelerometer (if given)

u_r is the model's mass-normalised shape at the test points, y_r the measured one (both in
1/sqrt(kg), so the shapes carry the absolute mass scale: the scale weight fixes the total, the
accelerometer shows in the amplitude and curvature near the driving point). sigma_f is the
relative frequency uncertainty, sigma_s that of a shape entry relative to its mode's RMS,
sigma_b that of a (heavily damped) suspension frequency. a_j is the measured mass line (the
rigid-body flexibility 1/M + (x_j - x_c)(x_s - x_c)/I of the bat with its accelerometer, 1/kg,
from the FRFs' lower residual: ema.shapes.mass_line) and G_j the model's
(updating.diagnose.model.rigid_flexibility); sigma_g the scatter of a_j about its straight
line (physics makes it one). E does not enter it: it is what separates the accelerometer's
mass from the modulus. m_s(data sheet) is meta.json's accelerometer_mass_g (sigma_p 0.3 g);
the model's m_s is 0 when the sensor_mass extension is off.
Solved by scipy's trust-region reflective least squares with the analytic Jacobian
(updating.diagnose.model), through updating.lsq; parameter covariance s^2 (J^T J)^+ with
s^2 = SSR / (N - p) (updating.lsq.covariance).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ema.shapes.mac import mac
from updating.diagnose.model import (
    BOUNDS,
    ModalSensitivities,
    Setup,
    State,
    free_parameters,
    from_vector,
    modal_sensitivities,
    rigid_flexibility,
    to_vector,
)
from updating.lsq import covariance, solve_bounded


@dataclass(frozen=True)
class Observations:
    """The measured data a fit matches.

    Attributes
    ----------
    freq_hz : np.ndarray
        (m,) paired elastic frequencies, Hz.
    shapes : np.ndarray
        (n_points, m) their mass-normalised shapes at the test points.
    model_index : np.ndarray
        (m,) the paired elastic mode of the model (0 = first elastic).
    sigma_f : float
        Relative frequency uncertainty (residual scale).
    sigma_s : float
        Uncertainty of a shape entry relative to its mode's RMS.
    suspension_hz : np.ndarray
        (<= 2,) measured suspension (rigid-body) frequencies, Hz.
    sigma_b : float
        Their relative uncertainty.
    code : np.ndarray | None
        (m,) 0 / 1: plane 1's / plane 2's member of a split pair (two bending planes seen), 2: a
        mode seen once, 3: a peak holding both planes' members (compared with their mix)
        (updating.diagnose.plane_pairs); None: all seen once.
    combined : np.ndarray | None
        (n_points, m) for plane 1's member of a pair its shape scaled to carry the pair's
        amplitude sqrt(|y_1|^2 + |y_2|^2) (what a one-plane model predicts), else the measured
        shape; None: the shapes.
    mass_line : np.ndarray | None
        (n_points,) measured mass line at the test points, 1/kg, or None.
    sigma_ml : float
        Its standard uncertainty per point, 1/kg.
    sensor_prior_g : float | None
        The accelerometer's mass from the lab's data sheet, g, or None.
    sigma_prior_g : float
        Its standard uncertainty, g.
    """

    freq_hz: np.ndarray
    shapes: np.ndarray
    model_index: np.ndarray
    sigma_f: float = 5e-4
    sigma_s: float = 0.01
    suspension_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sigma_b: float = 0.01
    code: np.ndarray | None = None
    combined: np.ndarray | None = None
    mass_line: np.ndarray | None = None
    sigma_ml: float = 1.0
    sensor_prior_g: float | None = None
    sigma_prior_g: float = 0.3

    @property
    def n_model_modes(self) -> int:
        """Return the number of model elastic modes the pairing reaches (highest index + 1)."""
        return int(self.model_index.max()) + 1

    @property
    def codes(self) -> np.ndarray:
        """Return the split-pair code of every mode (2, seen once, when ``code`` is None)."""
        return np.full(self.freq_hz.size, 2) if self.code is None else self.code

    @property
    def n_split(self) -> int:
        """Number of split pairs (both bending planes seen)."""
        return int(np.sum(self.codes == 1))


def columns(
    sol: ModalSensitivities, obs: Observations,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Map measured modes to model columns.

    A one-plane model predicts a pair once (plane 1's member, with the pair's combined
    shape), the two-plane model each member, and a peak holding both with the planes' mix
    (module docstring of updating.diagnose.model).

    Returns
    -------
    model_column : ndarray
        The model column of each measured mode.
    shape_modes : ndarray
        The measured modes with a shape residual.
    shapes : ndarray
        Their measured shapes.
    """
    code = obs.codes
    if sol.n_planes == 2:
        k = sol.elastic_hz.size // 4
        rows = np.arange(code.size)
        return obs.model_index + k * code, rows, obs.shapes
    rows = np.flatnonzero(code != 1)
    y = obs.shapes if obs.combined is None else obs.combined
    return obs.model_index, rows, y[:, rows]


@dataclass(frozen=True)
class DiagnosisFit:
    """One fitted model: its extensions, parameters, modes and residuals.

    Attributes
    ----------
    active : frozenset[str]
        The extensions switched on.
    state : State
        Fitted parameter values (inactive ones as given).
    names : tuple[str, ...]
        The free parameters.
    x, cov : np.ndarray
        Their values and their covariance.
    model_hz : np.ndarray
        (m,) model frequencies of the paired modes.
    mac : np.ndarray
        (m,) their MAC with the measured shapes.
    shapes : np.ndarray
        (n_points, m) the model's mass-normalised shapes of the paired modes.
    rms_pct : float
        RMS of 100 (f_model / f_measured - 1) over the paired modes.
    ssr_freq, ssr_shape : float
        Sums of squared frequency and shape residuals (the suspension residuals, present only
        with that extension, are left out so that fits of different extensions compare).
    ssr_mass : float
        Sum of squared mass-line and data-sheet residuals (present in every fit).
    mass_line : np.ndarray | None
        (n_points,) the model's mass line at the test points, 1/kg.
    """

    active: frozenset[str]
    state: State
    names: tuple[str, ...]
    x: np.ndarray
    cov: np.ndarray
    model_hz: np.ndarray
    mac: np.ndarray
    shapes: np.ndarray
    rms_pct: float
    ssr_freq: float
    ssr_shape: float
    ssr_mass: float = 0.0
    mass_line: np.ndarray | None = None

    def chi2(self, sigma_f: float) -> float:
        """(ssr_freq + ssr_shape + ssr_mass) / sigma_f^2."""
        return (self.ssr_freq + self.ssr_shape + self.ssr_mass) / sigma_f**2

    def std(self, name: str) -> float:
        """Return a free parameter's standard uncertainty (its own units: ln, grams or kN/m)."""
        i = self.names.index(name)
        return float(np.sqrt(max(self.cov[i, i], 0.0)))


def residuals(sol: ModalSensitivities, obs: Observations, with_suspension: bool):
    """(residual vector, Jacobian (N, p)) of one modal solution."""
    idx, rows, y = columns(sol, obs)
    f_ratio = sol.elastic_hz[idx] / obs.freq_hz
    res = [f_ratio - 1.0]
    jac = [(f_ratio[None, :] * sol.dlnf[:, idx]).T]
    u = sol.shapes[:, idx[rows]]
    du = sol.dshapes[:, :, idx[rows]]
    sign = np.where(np.sum(u * y, axis=0) < 0, -1.0, 1.0)
    w = obs.sigma_f / obs.sigma_s / np.sqrt(np.mean(y * y, axis=0))
    res.append((w * (y - sign * u)).ravel())
    jac.append(-(w * sign * du).reshape(du.shape[0], y.size).T)
    if with_suspension and obs.suspension_hz.size:
        meas = np.sort(obs.suspension_hz)[:2]
        if meas.size == 2:
            idx = np.arange(2)
        else:  # one suspension mode seen: the nearer of bounce and pitch
            with np.errstate(divide="ignore"):
                idx = np.array([np.argmin(np.abs(np.log(sol.low_hz / meas[0])))])
        r = sol.low_hz[idx] / meas
        w = obs.sigma_f / obs.sigma_b
        res.append(w * (r - 1.0))
        jac.append((w * r[None, :] * sol.dlnf_low[:, idx]).T)
    return np.concatenate(res), np.vstack(jac)


def scale_residuals(
    setup: Setup, active: frozenset[str], state: State, names: tuple[str, ...],
    obs: Observations,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Build the residuals of the mass line and of the data-sheet accelerometer mass.

    See the module docstring; empty when neither is given.

    Returns
    -------
    residuals : ndarray
        The residuals.
    jacobian : ndarray
        (N, p) their derivatives.
    mass_line : ndarray
        The model's mass line.
    """
    g, dg = rigid_flexibility(setup, active, state, names)
    res, jac = [np.zeros(0)], [np.zeros((0, len(names)))]
    if obs.mass_line is not None:
        w = obs.sigma_f / obs.sigma_ml
        res.append(w * (g - obs.mass_line))
        jac.append(w * dg.T)
    if obs.sensor_prior_g is not None:
        w = obs.sigma_f / obs.sigma_prior_g
        mass_g = 1e3 * state.sensor_mass_kg if "sensor_mass" in active else 0.0
        res.append(np.array([w * (mass_g - obs.sensor_prior_g)]))
        row = np.zeros((1, len(names)))
        if "sensor_g" in names:
            row[0, names.index("sensor_g")] = w
        jac.append(row)
    return np.concatenate(res), np.vstack(jac), g


def fit_model(
    setup: Setup, active: frozenset[str], obs: Observations, start: State,
) -> DiagnosisFit:
    """Fit the free parameters of the extensions ``active`` to ``obs`` from ``start``."""
    names = free_parameters(active, setup)
    n_modes = obs.n_model_modes
    with_susp = "suspension" in active
    cache: dict[bytes, tuple[np.ndarray, np.ndarray, ModalSensitivities, np.ndarray]] = {}

    def evaluate(x):
        key = np.asarray(x, dtype=float).tobytes()
        if key not in cache:
            cache.clear()
            state = from_vector(start, names, x)
            sol = modal_sensitivities(setup, active, state, n_modes, names)
            res, jac = residuals(sol, obs, with_susp)
            r_m, j_m, g = scale_residuals(setup, active, state, names, obs)
            cache[key] = (np.concatenate([res, r_m]), np.vstack([jac, j_m]), sol, g)
        return cache[key]

    if names:
        lo = np.array([BOUNDS[n][0] for n in names])
        hi = np.array([BOUNDS[n][1] for n in names])
        x = solve_bounded(
            lambda x: evaluate(x)[0], to_vector(start, names), lo, hi,
            jac=lambda x: evaluate(x)[1], margin=1e-9 * (hi - lo), x_scale="jac", xtol=1e-10,
            ftol=1e-12, gtol=1e-12, max_nfev=60).x
    else:
        x = np.zeros(0)
    res, jac, sol, g = evaluate(x)
    n_mass = (0 if obs.mass_line is None else obs.mass_line.size) + (
        obs.sensor_prior_g is not None)
    mass_res = res[res.size - n_mass:]
    idx, rows, _ = columns(sol, obs)
    m = obs.freq_hz.size
    k = m + obs.shapes.shape[0] * rows.size
    cov = covariance(jac, res, s2_default=obs.sigma_f**2)
    model_hz = sol.elastic_hz[idx]
    shapes = sol.shapes[:, idx]
    mac_values = np.diag(mac(obs.shapes, shapes))
    rms = float(100 * np.sqrt(np.mean((model_hz / obs.freq_hz - 1) ** 2)))
    return DiagnosisFit(frozenset(active), from_vector(start, names, x), names, x, cov, model_hz,
                        mac_values, shapes, rms, float(res[:m] @ res[:m]),
                        float(res[m:k] @ res[m:k]), float(mass_res @ mass_res), g)


def shape_sigma(fit: DiagnosisFit, obs: Observations, floor: float) -> float:
    """Estimate the random scatter of the measured shape entries about a fitted model's.

    Relative to each mode's RMS, once each mode's own scale q is taken out (so a wrong mass
    scale does not pass for noise): median over modes of |y - q u| / |y| sqrt(n / (n - 1)),
    at least ``floor``.
    """
    u, y = fit.shapes, obs.shapes
    q = np.sum(u * y, axis=0) / np.sum(u * u, axis=0)
    n = y.shape[0]
    rel = np.linalg.norm(y - q * u, axis=0) / np.linalg.norm(y, axis=0) * np.sqrt(n / max(n - 1, 1))
    return max(floor, float(np.median(rel)))
