"""Nonlinear least-squares fit of the change model to a re-test, relative to the baseline.

Data (paired modes r, test points j): the measured changes

    y_f[r]    = ln(f_retest[r] / f_baseline[r])
    y_psi[j,r] = psi_retest[j,r] - psi_baseline[j,r]        (mass-normalised shapes)
    y_w       = ln(W_retest / W_registered)                   (when both weights are known)

are matched by the model's changes from the reference, ln(f(theta)/f(0)),
phi(theta) - phi(0) and ln(m(theta)/m(0)) (m: the wood's mass), so that what the calibrated
reference gets wrong (and the test's own bias) largely cancels. Residuals are weighted by
their standard deviations: sigma_f from the modal fit's frequency uncertainties (with a
model-error floor), sigma_psi[j,r] = sigma_r * psi_scale[j,r] (a relative shape-noise
level per mode, estimated from the residuals, ``shape_noise``; psi_scale ~ sqrt(phi0[j,r]^2 +
k^2 rms_r^2), the noise of an FRF relative to |H| with a floor near the nodes,
``changes.SHAPE_NOISE_FLOOR_SHARE``),
sigma_w = ``WEIGHT_SIGMA_REL``. Parameters:

    null (what an unaltered bat does between tests, physically bounded, ``NullBounds``):
          x = [x0, 100 (s_rho - 1), sensor shift (in),
               end-grain moisture at the knob end (points), at the barrel end (points),
               change of the accelerometer's mass (g), two-plane mix c,
               grip substance added on the handle (g), where it ends and starts (in from
               the knob end)]
          with s_E = 1 + (x0 - 2 x1) / 100: moisture's stiffness coupled to its mass, x0 the
          temperature's share (``MOISTURE_COUPLING``)
    core: x = null + [plug (in), filled length (in), p = r b, q = (R - r) b]

with b = (d / 1 in)^2 for core diameter d, fill density ratio r in [0, R]: the box p, q >= 0
is exactly the cone of physical cores, b = (p + q) / R and r = R p / (p + q). The filled part
runs from ``plug`` to ``plug + length`` from the barrel end (a plug of wood, or nothing, at
the end): end-bored cores, cores starting inside the bat, empty holes (r = 0) and heavy end
plugs (short, r > 1) are all of this family. The core's mass change (r - 1) b and its
stiffness change (shear through the section's area and Cowper's coefficient ~ b, bending
~ b^2) are nearly linear in (p, q), so the model has a non-vanishing gradient at "no core".

The core fit starts from the best (plug, length) of a linearised scan (the residual
projected on the null model's Jacobian and on the responses to a stiffness-only and a
mass-only core there), which avoids the local minima of the position.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from updating.inspect.kind_table import FAMILIES
from updating.inspect.model import E_PER_POINT, MASS_PER_POINT, ChangeParams, ChangePredictor
from updating.inspect.moisture_bounds import NOMINAL, MoistureBound
from updating.inspect.parallel import fork_map
from updating.inspect.segments import Segment
from updating.inspect.sensitivity import predicted_change
from updating.lsq import LsqSolution, solve_bounded
from updating.lsq import covariance as lsq_covariance
from updating.model.profile import Profile
from updating.model.sections import Core
from updating.model.units import IN_TO_M

SigmaRel = float | np.ndarray
"""Relative shape noise: one level, or (m,) one per paired mode (``shape_noise``)."""
N_NULL = 10
N_CORE = len(FAMILIES["core"].names)
CORE_PLUG, CORE_LENGTH = (N_NULL + FAMILIES["core"].index(n) for n in ("plug_in", "length_in"))
"""Where the core's plug and filled length (in) sit in x (``kind_table.FAMILIES``)."""
NULL_NAMES = ("stiffness_beyond_moisture_pct", "density_pct", "sensor_shift_in",
              "knob_end_moisture_pt", "barrel_end_moisture_pt", "sensor_mass_change_g",
              "plane_mix", "handle_substance_g", "handle_substance_to_in",
              "handle_substance_from_in")
NULL_INDEX = {name: i for i, name in enumerate(NULL_NAMES)}
"""Where each null parameter sits in x (``NULL_NAMES``): H0's parameters by name."""
END_MOISTURE_NAMES = ("knob_end_moisture_pt", "barrel_end_moisture_pt")
"""The end grain's moisture excess (``NULL_NAMES``)."""
HANDLE_MAX_G = 40.0
"""Most grip substance considered on the handle between tests, g: tape 5-25 g, pine tar and
spray 1-8 g (Rule 3.02(c) allows any amount within 18 in of the knob)."""
HANDLE_MAX_IN, HANDLE_MIN_IN = 18.0, 4.0
"""Reach of a legal grip substance from the knob end (Rule 3.02(c)), and the shortest reach
fitted (a substance covers at least a hand's width)."""
GRIP_G, GRIP_TO, GRIP_FROM = (NULL_INDEX[n] for n in ("handle_substance_g",
                                                      "handle_substance_to_in",
                                                      "handle_substance_from_in"))
"""Where the grip substance's mass (g), reach and start (in from the knob end) sit in x."""
GRIP = [GRIP_G, GRIP_TO, GRIP_FROM]
GRIP_PLACE = (GRIP_TO, GRIP_FROM)
"""The grip substance's reach and start (``NullBounds.held`` skips them)."""
HANDLE_FROM_MAX_IN = 3.0
"""Furthest from the knob end a grip substance is taken to start (tape and pine tar start
0.5-2 in from the end, past the knob)."""
R_MAX = 6.0  # densest fill considered, relative to the wood
MIN_PLUG_IN, MIN_LENGTH_IN = 0.05, 2.0
"""The shortest filled length considered a core: end plugs are 2-4 in, corks 3-12 in. A
shorter 'core' at the barrel end fits what the accelerometer and cupped end do there (on
clean nuisance-rich bats such 1 in 'cores' reached F = 13)."""
CORE_LOWER = np.array([MIN_PLUG_IN, MIN_LENGTH_IN, 0.0, 0.0])
CORE_UPPER = np.array([12.0, 15.0, 2.6 * R_MAX, 2.6 * R_MAX])
MIN_B = 1e-4  # (0.01 in)^2: the smallest core diameter the model builds
MAX_NFEV_START, MAX_NFEV_CORE = 15, 30
"""Caps on core-fit iterations (each start, final refinement): a real core converges in
fewer; without one the position is unidentifiable and the optimiser would wander (an
unconverged H1 fit only lowers F)."""
DIFF_STEP = 1e-4
"""Finite-difference step, absolute, in x's units (%, in, points, g): well above the
eigen-solution's rounding, well below any change that matters."""
HELD_WITHIN = 0.002
"""A fitted parameter within this share of its range of a bound is held there
(``NullBounds.held``): the fit stops by its tolerances, and a sensor shift 0.0003 in short
of its 0.3 in bound on a hidden-core test bat was not marked and skipped the check that a
core is told apart from that drift."""
WEIGHT_SIGMA_REL = 0.003
"""Standard deviation of ln(W_retest / W_registered) beyond the modelled drift: two scales,
tape and dirt (0.3 %, ~0.1 oz on a 2.2 lb bat)."""
PRIOR_SHIFT_IN, PRIOR_SENSOR_MASS_G = 0.1, 2.0
"""Prior standard deviations of the accelerometer's re-mounting shift and an unknown
replacement accelerometer's mass change (the moisture's: ``moisture_bounds``)."""
FREQ_MODEL_ERROR_REL = 3e-4
"""Floor on the relative frequency-change uncertainty: what the 1D change model misses in a
change of frequency (suspension, mesh)."""
PLANE_SPLIT_REL = (0.003, 0.013, 0.023, 0.030, 0.047, 0.056)
"""Split of the two bending planes' frequencies, elastic modes 1-6 (3D analysis of a smooth
ash bat); beyond mode 6 the last value."""
PLANE_MIX = 0.15
"""Fraction of the plane split kept as frequency noise beside the fitted plane mix
(``PLANE_MIX_MAX``): what the linear model of the mix misses (a fit resolving part of a
pair; the mix's effect on the shapes is modelled, ``plane_shape_shift``)."""
MOISTURE_COUPLING = E_PER_POINT / MASS_PER_POINT
"""Stiffness % per density % of a uniform moisture change (-2: E -2 % per +1 % mass per
point): H0's uniform stiffness is s_E = 1 + (x0 + MOISTURE_COUPLING x1) / 100 with x1 the
density % (moisture) and x0 what temperature does (0 would make the two scales free)."""
COUPLING_SLACK_PCT = 1.0
"""Freedom of x0 beyond temperature's range (-0.1..-0.3 %/C of the known change, else
+-10 C): a coupling of wood that is not exactly -2 (1 % of stiffness is +-0.33 %/point at
the largest drift), the temperature's own reading."""
PLANE_MIX_MAX, PRIOR_PLANE_MIX = 0.15, 0.05
"""Bound and prior sd of the two-plane mix c = Delta(sin^2 theta) ln(EG_T / EG_R): the
apparent frequency of a pair tapped at theta to the radial plane is ln f = ln f_R +
sin^2(theta) ln(f_T / f_R), and ln(f_T / f_R) = S_r ln(EG_T / EG_R) with S_r = d ln f_r /
d ln(E/G) of the reference; a re-test tapped within +-10 deg of the baseline's angle moves
sin^2(theta) by up to sin(10 deg) = 0.17, the planes' E/G differ by up to ~1.8x (ln 0.58):
|c| <= 0.1, bounded at 0.15."""


def plane_sigma(elastic_order: np.ndarray) -> np.ndarray:
    """Return the frequency spread of the two bending planes per mode.

    Standard deviation of ln f change from the two bending planes, per elastic mode
    (0-based order among the elastic modes).
    """
    split = np.asarray(PLANE_SPLIT_REL)
    return PLANE_MIX * split[np.minimum(np.asarray(elastic_order, dtype=int), split.size - 1)]


@dataclass(frozen=True)
class NullBounds:
    """Physical bounds of the null parameters.

    Physical bounds of the null parameters (x[:N_NULL], module docstring), from
    ../docs/inspection.md: moisture as the lab's records bound it (``moisture_bounds``;
    without records +-3 points, E -2 %, mass +1 % per point, end grain up to 2.5 points
    beyond the middle), temperature +-10 C (E -0.1..-0.3 %/C), the sensor re-mounted within
    0.3 in, a replacement accelerometer within 0-10 g (or its known mass within 0.3 g).
    """

    lower: np.ndarray
    upper: np.ndarray
    prior_center: np.ndarray
    prior_sigma: np.ndarray
    """Gaussian prior on each null parameter (inf: none): keeps the nearly interchangeable
    nuisances (end-grain moisture at the barrel end, the accelerometer's mass and position)
    at their typical sizes unless the data insist."""

    @staticmethod
    def physical(sensor_change_kg: float | None = None,
                 temperature_change_c: float | None = None,
                 moisture: MoistureBound = NOMINAL) -> NullBounds:
        """Return the physical bounds, narrowed by what the lab recorded.

        ``sensor_change_kg``: the change of accelerometer mass when both tests' masses
        are known (else fitted within +-10 g, prior ``PRIOR_SENSOR_MASS_G``: the calibrated
        reference's own sensor mass can hold other physics, even be 0 g, so the change is
        not bounded by it); ``temperature_change_c``: re-test minus baseline temperature
        when both are known; ``moisture``: the uniform moisture's and the end grain's
        bounds and priors (``moisture_bounds.moisture_bound``; ``NOMINAL`` without records).
        """
        if temperature_change_c is None:
            t_lo, t_hi = -3.0, 3.0
        else:
            a, b = -0.1 * temperature_change_c, -0.3 * temperature_change_c
            t_lo, t_hi = min(a, b) - 0.3, max(a, b) + 0.3
        if sensor_change_kg is None:
            m_lo, m_hi, m0, m_sig = -10.0, 10.0, 0.0, PRIOR_SENSOR_MASS_G
        else:
            m0 = 1e3 * sensor_change_kg
            m_lo, m_hi, m_sig = m0 - 0.3, m0 + 0.3, 0.1
        if MOISTURE_COUPLING:  # stiffness beyond the moisture's coupled share
            s_lo, s_hi = t_lo - COUPLING_SLACK_PCT, t_hi + COUPLING_SLACK_PCT
        else:
            s_lo, s_hi = -5.5 + t_lo, 5.5 + t_hi
        inf = np.inf
        by_name = {  # name: lower, upper, prior centre, prior sd
            "stiffness_beyond_moisture_pct": (s_lo, s_hi, 0.0, inf),
            "sensor_shift_in": (-0.3, 0.3, 0.0, PRIOR_SHIFT_IN),
            "sensor_mass_change_g": (m_lo, m_hi, m0, m_sig),
            "plane_mix": (-PLANE_MIX_MAX, PLANE_MIX_MAX, 0.0, PRIOR_PLANE_MIX),
            "handle_substance_g": (0.0, HANDLE_MAX_G, 0.0, inf),
            "handle_substance_to_in": (HANDLE_MIN_IN, HANDLE_MAX_IN, 10.0, inf),
            "handle_substance_from_in": (0.0, HANDLE_FROM_MAX_IN, 1.0, inf),
            **{n: (p.lower, p.upper, p.center, p.sd) for n, p in moisture.by_name().items()},
        }
        lo, hi, center, sigma = (np.array(c, dtype=float)
                                 for c in zip(*(by_name[n] for n in NULL_NAMES), strict=True))
        return NullBounds(lo, hi, center, sigma)

    def widened(self) -> NullBounds:
        """Return the bounds with the uniform stiffness and density free.

        The same with the uniform stiffness and density free (+-40 %, +-30 %): what
        another bat of the same profile, or a drift far beyond physics, would need.
        """
        lo, hi = self.lower.copy(), self.upper.copy()
        uniform = [NULL_INDEX["stiffness_beyond_moisture_pct"], NULL_INDEX["density_pct"]]
        lo[uniform], hi[uniform] = (-40.0, -30.0), (40.0, 30.0)
        return NullBounds(lo, hi, self.prior_center, self.prior_sigma)

    def relaxed(self, factor: float = 3.0, only: tuple[str, ...] | None = None,
                ranges: dict[str, tuple[float, float]] | None = None) -> NullBounds:
        """Return the bounds widened about their middles.

        Every range ``factor`` times as wide about its middle (priors kept): to ask whether
        the data really want a nuisance beyond its physical bound. With ``only`` (names of
        ``NULL_NAMES``) just those ranges, the others held where physics holds them.
        ``ranges`` (name: (lower, upper)) gives a widened range of its own to the names it
        holds (the moisture's, ``MoistureBound.beyond_ranges``).
        """
        mid, half = 0.5 * (self.lower + self.upper), 0.5 * (self.upper - self.lower)
        lo, hi = mid - factor * half, mid + factor * half
        for name, (r_lo, r_hi) in (ranges or {}).items():
            i = NULL_INDEX[name]
            lo[i], hi[i] = min(r_lo, self.lower[i]), max(r_hi, self.upper[i])
        if only is not None:
            free = np.isin(np.array(NULL_NAMES), only)
            lo, hi = np.where(free, lo, self.lower), np.where(free, hi, self.upper)
        lo[GRIP], hi[GRIP] = self.lower[GRIP], self.upper[GRIP]  # a grip substance stays one
        return NullBounds(lo, hi, self.prior_center, self.prior_sigma)

    def prior_residual(self, x: np.ndarray) -> np.ndarray:
        """Return the priors' weighted residuals at ``x``."""
        return (x[:N_NULL] - self.prior_center) / self.prior_sigma

    @staticmethod
    def held(fit: ChangeFit) -> list[str]:
        """Names of the null parameters a bound holds in ``fit`` (the data want more).

        A grip substance's start and reach are left out: their bounds are where a grip is
        (the knob, Rule 3.02(c)'s 18 in), not a drift's physical limit.
        """
        active = np.flatnonzero(fit.active[:N_NULL])
        return [NULL_NAMES[i] for i in active if i not in GRIP_PLACE]


@dataclass(frozen=True)
class Differences:
    """Measured changes between the tests, their weights and the reference's modes.

    Attributes
    ----------
    model_index
        (m,) index of each pair's mode among the predictor's modes.
    dlnf
        (m,) ln(f_retest / f_baseline)
    sigma_lnf
        (m,) its standard deviation.
    dpsi
        (n_points, m) retest minus baseline shapes (signs aligned).
    psi_scale
        (n_points, m) shape-noise scale of each entry: sqrt(rms_baseline^2 + rms_retest^2) of
        the mode, shared among its points as sqrt(phi0^2 + k^2 rms0^2)
        (``changes.SHAPE_NOISE_FLOOR_SHARE``: noise relative to |phi| with a floor).
    f0
        (m,) reference model frequencies, Hz.
    phi0
        (n_points, m) its shapes, aligned.
    dlnw
        ln(W_retest / W_registered), or None when a weight is missing.
    mass0_kg
        The reference's wood mass (the model's weight before any change).
    plane_sens
        (m,) S_r = d ln f_r / d ln(E/G) of the reference (the two-plane mix's effect on each
        pair's ln f per unit c), or None (no plane mix).
    plane_shape_sens
        (n_points, m) d phi_r / d ln(E/G), aligned as phi0 (the mix's effect on each pair's
        shape per unit c), or None.
    rows
        (n_points,) which of the predictor's test points the shape rows are, or None (all,
        in order): a point left out (``without_point``).
    sigma_meas
        (m,) relative shape noise of each paired mode as both tests measured it (their
        coherence: ``ema.shapes.noise``; ``changes.measured_shape_noise``, with the change
        model's own error in quadrature); None when either test carries no coherence.
    """

    model_index: np.ndarray
    dlnf: np.ndarray
    sigma_lnf: np.ndarray
    dpsi: np.ndarray
    psi_scale: np.ndarray
    f0: np.ndarray
    phi0: np.ndarray
    dlnw: float | None = None
    mass0_kg: float = 1.0
    plane_sens: np.ndarray | None = None
    plane_shape_sens: np.ndarray | None = None
    rows: np.ndarray | None = None
    sigma_meas: np.ndarray | None = None

    def without_mode(self, k: int) -> Differences:
        """Return the changes with paired mode ``k`` left out."""
        keep = np.arange(self.n_freq) != k
        return replace(self, model_index=self.model_index[keep], dlnf=self.dlnf[keep],
                       sigma_lnf=self.sigma_lnf[keep], dpsi=self.dpsi[:, keep],
                       psi_scale=self.psi_scale[:, keep], f0=self.f0[keep],
                       phi0=self.phi0[:, keep],
                       plane_sens=None if self.plane_sens is None else self.plane_sens[keep],
                       plane_shape_sens=None if self.plane_shape_sens is None
                       else self.plane_shape_sens[:, keep],
                       sigma_meas=None if self.sigma_meas is None else self.sigma_meas[keep])

    def without_point(self, j: int) -> Differences:
        """Return the changes with the shape row of test point ``j`` (a row here) left out."""
        keep = np.arange(self.dpsi.shape[0]) != j
        rows = np.arange(self.dpsi.shape[0]) if self.rows is None else self.rows
        return replace(self, dpsi=self.dpsi[keep], psi_scale=self.psi_scale[keep],
                       phi0=self.phi0[keep], rows=rows[keep],
                       plane_shape_sens=None if self.plane_shape_sens is None
                       else self.plane_shape_sens[keep])

    def point_rows(self, shapes: np.ndarray) -> np.ndarray:
        """Return the rows of the predictor's ``shapes`` (points first) these changes use."""
        return shapes if self.rows is None else shapes[self.rows]

    @property
    def n_freq(self) -> int:
        """Return the number of frequency data."""
        return self.dlnf.size

    @property
    def n_data(self) -> int:
        """Return the number of data (frequencies, shapes, weight)."""
        return self.dlnf.size + self.dpsi.size + (self.dlnw is not None)


@dataclass(frozen=True)
class ChangeFit:
    """A change fit.

    A change fit: the least-squares solution (x, weighted residual, Jacobian in x units,
    active bounds), the bat's state it stands for, and where the residual's blocks are
    (``n_freq`` frequency rows, then ``n_psi`` shape rows).
    """

    solution: LsqSolution
    params: ChangeParams
    n_freq: int
    n_psi: int

    @property
    def x(self) -> np.ndarray:
        """Return the solution, in x units."""
        return self.solution.x

    @property
    def residual(self) -> np.ndarray:
        """Return the weighted residual at the solution."""
        return self.solution.residual

    @property
    def jac(self) -> np.ndarray:
        """Return the Jacobian at the solution, in x units."""
        return self.solution.jac

    @property
    def active(self) -> np.ndarray:
        """(len(x),) -1 / +1 where a lower / upper bound holds the solution, else 0."""
        return self.solution.active

    @property
    def rss(self) -> float:
        """Return the weighted residual sum of squares."""
        return self.solution.ssr

    @property
    def shape_residual(self) -> np.ndarray:
        """(n_points, m) weighted shape residual (``Differences.dpsi``'s layout)."""
        return self.residual[self.n_freq:self.n_freq + self.n_psi].reshape(-1, self.n_freq)


@dataclass(frozen=True)
class ParamSpace:
    """How a parameter vector becomes a state of this bat (``ChangeParams``).

    ``sensor_mount_m`` is the nominal move of the accelerometer between the tests (the
    difference of the labelled sensor points); the fitted shift is added to it.
    ``moisture`` is what the lab's records say of the moisture (``bounds`` holds its H0
    ranges; the check beyond drift reads its wider ranges and deeper front).
    """

    profile: Profile
    bounds: NullBounds
    fill_modulus_ratio: float = 0.0
    sensor_mount_m: float = 0.0
    moisture: MoistureBound = NOMINAL

    def lower(self) -> np.ndarray:
        """Return the lower bounds of x."""
        return np.concatenate([self.bounds.lower, CORE_LOWER])

    def upper(self) -> np.ndarray:
        """Return the upper bounds of x."""
        return np.concatenate([self.bounds.upper, CORE_UPPER])

    def core(self, plug_in: float, length_in: float, p: float, q: float,
             empty_fraction: float = 0.0) -> Core:
        """Return the core of x[N_NULL:].

        The core of x[N_NULL:]; depth kept within 95 % of the bat, diameter clipped to 90 %
        of the thinnest outer diameter it spans; ``empty_fraction`` of the hole, behind the
        plug, left empty (``fit_partial``).
        """
        L = self.profile.length_m
        plug = plug_in * IN_TO_M
        depth = min(plug + length_in * IN_TO_M, 0.95 * L)
        plug = min(plug, depth - MIN_LENGTH_IN * IN_TO_M)
        xs = np.linspace(L - depth, L - plug, 25)
        b = max((p + q) / R_MAX, MIN_B)
        r = R_MAX * p / (p + q) if p + q > 0 else 1.0
        d = min(np.sqrt(b) * IN_TO_M, 0.9 * float(np.min(self.profile.diameter_at(xs))))
        return Core(d, depth, r, self.fill_modulus_ratio, plug, empty_fraction * (depth - plug))

    def reading(self, x: np.ndarray, cov: np.ndarray) -> dict:
        """Read the core of x with its standard uncertainties.

        Core start (m from the knob end), diameter (m), fill ratio (averaged over the hole
        when part of it is empty) and their standard uncertainties from the covariance of x
        (first-order propagation).
        """
        _, _, p, q = x[N_NULL:N_NULL + N_CORE]
        e = float(x[N_NULL + N_CORE]) if x.size > N_NULL + N_CORE else None
        s = max(p + q, R_MAX * MIN_B)
        b = s / R_MAX
        dd = IN_TO_M / (2 * np.sqrt(b)) / R_MAX
        kept = 1.0 if e is None else 1.0 - e
        grads = {"region_start_m": np.array([-IN_TO_M, -IN_TO_M, 0.0, 0.0]),
                 "core_diameter_m": np.array([0.0, 0.0, dd, dd]),
                 "fill_density_ratio": kept * R_MAX * np.array([0.0, 0.0, q, -p]) / s**2}
        if e is not None:
            grads = {k: np.append(g, 0.0) for k, g in grads.items()}
            grads["fill_density_ratio"][-1] = -R_MAX * p / s
        c = cov[N_NULL:, N_NULL:]
        sd = {k: float(np.sqrt(max(g @ c @ g, 0.0))) for k, g in grads.items()}
        return {"core": self.core(*x[N_NULL:]), "sd": sd}

    def params(self, x: np.ndarray) -> ChangeParams:
        """Return x as the predictor's parameters (null part, then the core's)."""
        core = None if x.size == N_NULL else self.core(*x[N_NULL:])
        return null_params(x, self.sensor_mount_m, core=core)

    @staticmethod
    def to_x(plug_in: float, length_in: float, b: float, r: float) -> np.ndarray:
        """Core part of x for plug, length (in), b = (d / 1 in)^2 and fill ratio r."""
        return np.array([plug_in, length_in, r * b, (R_MAX - r) * b])


def handle_segment(x: np.ndarray) -> Segment | None:
    """Return the grip substance of the null part x[:N_NULL], or None when there is none.

    A surface layer from its start near the knob end to its reach.
    """
    mass_g, reach_in, from_in = float(x[GRIP_G]), float(x[GRIP_TO]), float(x[GRIP_FROM])
    if mass_g <= 0.0:
        return None
    return Segment(from_in * IN_TO_M, reach_in * IN_TO_M, added_mass_kg=mass_g * 1e-3,
                   mass_at_surface=True)


def null_params(x: np.ndarray, sensor_mount_m: float, core: Core | None = None,
                segments: tuple[Segment, ...] = ()) -> ChangeParams:
    """Return the bat's state for the null part of x (module docstring), a core or segments.

    Parameters
    ----------
    x : ndarray
        Parameter vector; its first ``N_NULL`` entries are read.
    sensor_mount_m : float
        Nominal move of the accelerometer between the tests, m.
    core : Core, optional
        An axial core (H1's core family).
    segments : tuple of Segment
        Local changes besides the grip substance (H1's segment families).
    """
    handle = handle_segment(x)
    segs = ((handle,) if handle is not None else ()) + tuple(segments)
    v = dict(zip(NULL_NAMES, x[:N_NULL], strict=True))
    return ChangeParams(
        1 + (v["stiffness_beyond_moisture_pct"] + MOISTURE_COUPLING * v["density_pct"]) / 100,
        1 + v["density_pct"] / 100, sensor_mount_m + v["sensor_shift_in"] * IN_TO_M, core,
        (float(v["knob_end_moisture_pt"]), float(v["barrel_end_moisture_pt"])),
        float(v["sensor_mass_change_g"]) * 1e-3, segs)


def plane_shift(diff: Differences, x: np.ndarray) -> np.ndarray:
    """(m,) ln f change of each pair from the two-plane mix c (``plane_mix``): S_r c."""
    if diff.plane_sens is None:
        return np.zeros(diff.n_freq)
    return diff.plane_sens * float(x[NULL_INDEX["plane_mix"]])


def plane_shape_shift(diff: Differences, x: np.ndarray) -> np.ndarray | float:
    """Return the shape change of the two-plane mix.

    (n_points, m) shape change of each pair from the two-plane mix c (``plane_mix``):
    dphi / d ln(E/G) c. The merged pair's shape is cos^2 phi_R + sin^2 phi_T
    (``updating.correlate.planes.merge_plane_pairs``), so tapping at another angle moves it by
    Delta(sin^2 theta) (phi_T - phi_R) = c dphi / d ln(E/G) to first order.
    """
    if diff.plane_shape_sens is None:
        return 0.0
    return diff.plane_shape_sens * float(x[NULL_INDEX["plane_mix"]])


@dataclass(frozen=True)
class Residual:
    """The weighted residual of a change fit as a function of x, and its Jacobian.

    ``residual(x)``: measured minus predicted change, weighted, length n_data, then the null
    parameters' prior residuals (N_NULL). ``jacobian(x, upper)``: its derivative from modal
    sensitivities (``sensitivity.predicted_change``), one eigen-solution for all columns.
    """

    predict: ChangePredictor
    diff: Differences
    space: ParamSpace
    sigma_rel: SigmaRel

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Return the weighted residual at x."""
        x = np.asarray(x, dtype=float)
        params = self.space.params(x)
        f, phi = self.predict(params)
        idx = self.diff.model_index
        f, phi = f[idx], self.diff.point_rows(phi)[:, idx]
        phi = phi * np.sign(np.einsum("ij,ij->j", phi, self.diff.phi0))
        mass = None if self.diff.dlnw is None else self.predict.wood_mass_kg(params)
        return self.weigh(x, f, phi, mass)

    def weigh(self, x: np.ndarray, f: np.ndarray, phi: np.ndarray,
              mass_kg: float | None) -> np.ndarray:
        """Return the weighted residual of predicted paired frequencies, aligned shapes, mass.

        Affine in ln f, the shapes, ln(mass) and x (``jacobian`` relies on it).
        """
        diff = self.diff
        rf = (diff.dlnf - np.log(f / diff.f0) - plane_shift(diff, x)) / diff.sigma_lnf
        rs = (diff.dpsi - (phi - diff.phi0) - plane_shape_shift(diff, x)) / (
            self.sigma_rel * diff.psi_scale)
        parts = [rf, rs.ravel()]
        if diff.dlnw is not None:
            dw = np.log(mass_kg / diff.mass0_kg)
            parts.append(np.array([(diff.dlnw - dw) / WEIGHT_SIGMA_REL]))
        parts.append(self.space.bounds.prior_residual(x))
        return np.concatenate(parts)

    def jacobian(self, x: np.ndarray, upper: np.ndarray) -> np.ndarray:
        """Return the Jacobian at x, (len(residual), len(x)).

        Each parameter stepped by ``DIFF_STEP`` (back from ``upper``) in the matrices only
        (``sensitivity.predicted_change``); since ``weigh`` is affine in what the modes give,
        a column is weigh's change for the first-order change of the modes, over the step.
        """
        x = np.asarray(x, dtype=float)
        params = self.space.params(x)
        h = np.where(x + DIFF_STEP <= upper, DIFF_STEP, -DIFF_STEP)
        xs = list(x + np.diag(h))
        steps = [(self.space.params(xi), float(hi)) for xi, hi in zip(xs, h, strict=True)]
        pc = predicted_change(self.predict, params, steps)
        idx = self.diff.model_index
        phi = self.diff.point_rows(pc.shapes)[:, idx]
        sign = np.sign(np.einsum("ij,ij->j", phi, self.diff.phi0))
        d_lnf = pc.d_lnf[idx]
        d_phi = self.diff.point_rows(pc.d_shapes)[:, idx] * sign[None, :, None]
        f, phi = pc.freq_hz[idx], phi * sign
        mass = d_lnm = None
        if self.diff.dlnw is not None:
            mass = self.predict.wood_mass_kg(params)
            d_lnm = [np.log(self.predict.wood_mass_kg(p) / mass) / hi for p, hi in steps]
        r0 = self.weigh(x, f, phi, mass)
        J = np.empty((r0.size, x.size))
        for i in range(x.size):
            mi = None if mass is None else mass * np.exp(h[i] * d_lnm[i])
            J[:, i] = (self.weigh(xs[i], f * np.exp(h[i] * d_lnf[:, i]),
                                  phi + h[i] * d_phi[:, :, i], mi) - r0) / h[i]
        return J


def residual_function(
    predict, diff: Differences, space: ParamSpace, sigma_rel: SigmaRel,
) -> Residual:
    """Build the weighted residual function of x (``Residual``)."""
    return Residual(predict, diff, space, sigma_rel)


def solver_functions(fun: Residual, upper: np.ndarray) -> tuple[Callable, Callable]:
    """Return (residual, Jacobian) for the solver; the residual of the last x is reused."""
    last: dict = {}

    def f(x: np.ndarray) -> np.ndarray:
        key = x.tobytes()
        if key not in last:
            last.clear()
            last[key] = fun(x)
        return last[key]

    return f, lambda x: fun.jacobian(x, upper)


def fit_bounded(fun: Residual, x0: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                space: ParamSpace, diff: Differences, max_nfev: int | None = None) -> ChangeFit:
    """Fit x within bounds.

    Bounded Gauss-Newton (trust-region reflective, ``updating.lsq.solve_bounded``) from
    x0, moved at least 1 % of the range inside the bounds: the first trust region is |x0|,
    so a start a hair inside a bound (x0 ~ 1e-9) would crawl.
    """
    f, jac = solver_functions(fun, upper)
    res = solve_bounded(f, x0, lower, upper, jac=jac, margin=0.01 * (upper - lower),
                        held_within=HELD_WITHIN * (upper - lower),
                        x_scale=1.0, ftol=1e-6, xtol=1e-6, max_nfev=max_nfev)
    return ChangeFit(res, space.params(res.x), diff.n_freq, diff.dpsi.size)


def fit_null(predict, diff: Differences, space: ParamSpace, sigma_rel: SigmaRel,
             x0: np.ndarray | None = None) -> ChangeFit:
    """Fit H0: what every bat does between tests.

    Moisture (uniform and end grain), temperature, the re-mounted or replaced accelerometer,
    a grip substance on the handle. Without ``x0`` the fit starts from the priors' centres
    (the grip substance from 1 in to 10 in) and, when it finds a substance of
    ``HANDLE_RESTART_G`` or more, again with its reach at each of
    ``HANDLE_REACH_STARTS_IN``: the reach is not identified while the mass is near 0, so
    one start can stop at the wrong one.
    """
    fun = residual_function(predict, diff, space, sigma_rel)
    b = space.bounds
    if x0 is not None:
        return fit_bounded(fun, x0, b.lower, b.upper, space, diff)
    start = np.clip(np.where(np.isfinite(b.prior_center), b.prior_center, 0.0), b.lower,
                    b.upper)
    best = fit_bounded(fun, start, b.lower, b.upper, space, diff)
    if best.x[GRIP_G] >= HANDLE_RESTART_G:
        for reach in HANDLE_REACH_STARTS_IN:
            x = best.x.copy()
            x[GRIP_TO] = reach
            fit = fit_bounded(fun, x, b.lower, b.upper, space, diff)
            best = fit if fit.rss < best.rss else best
    return best


HANDLE_RESTART_G = 0.5
HANDLE_REACH_STARTS_IN = (6.0, 12.0, 17.5)
"""When and where ``fit_null`` restarts the grip substance's reach."""


SCAN_PLUGS_IN = (0.1, 1.0, 3.0)
SCAN_LENGTHS_IN = (2.0, 4.0, 6.0, 9.0, 12.0)
"""Where the linearised scan puts trial cores (plug from the barrel end, filled length)."""


def position_scan(
    predict, diff: Differences, space: ParamSpace, sigma_rel: SigmaRel, null: ChangeFit,
    plugs_in=SCAN_PLUGS_IN, lengths_in=SCAN_LENGTHS_IN,
) -> tuple[np.ndarray, np.ndarray]:
    """Linearised scan: for each (plug, length), residual norm and seed x for the core fit.

    The change in residual from a 1 in core with density-neutral fill (b = 1, r = 1:
    stiffness only), and from making that fill massless (r = 0: mass only), are combined
    with the null Jacobian; the least-squares coefficients c_s, c_m seed b = c_s^0.8
    (stiffness ~ b^1.25) and r = 1 - c_m / b (mass change (r - 1) b = -c_m).
    """
    fun = residual_function(predict, diff, space, sigma_rel)
    r0 = null.residual
    norms, seeds = [], []
    for plug in plugs_in:
        for length in lengths_in:
            r_stiff = fun(np.concatenate([null.x, space.to_x(plug, length, 1.0, 1.0)]))
            r_mass = fun(np.concatenate([null.x, space.to_x(plug, length, 1.0, 0.0)]))
            A = np.column_stack([null.jac, r_stiff - r0, r_mass - r_stiff])
            coef, *_ = np.linalg.lstsq(A, -r0, rcond=None)
            norms.append(float(np.linalg.norm(r0 + A @ coef)))
            c_s, c_m = coef[N_NULL], coef[N_NULL + 1]
            b = float(np.clip(max(c_s, 0.0) ** 0.8, 0.01, 2.2))
            r = float(np.clip(1.0 - c_m / b, 0.05, R_MAX - 0.05))
            seeds.append(np.concatenate([null.x + coef[:N_NULL],
                                         space.to_x(plug, length, b, r)]))
    return np.array(norms), np.array(seeds)


def fit_core(
    predict, diff: Differences, space: ParamSpace, sigma_rel: SigmaRel, null: ChangeFit,
    n_starts: int = 2, x0: np.ndarray | None = None,
) -> ChangeFit:
    """Fit H1: the null model and a core, multi-start from the position scan (or from x0)."""
    fun = residual_function(predict, diff, space, sigma_rel)
    lo, hi = space.lower(), space.upper()
    if x0 is not None:
        return fit_bounded(fun, x0, lo, hi, space, diff, MAX_NFEV_CORE)
    norms, seeds = position_scan(predict, diff, space, sigma_rel, null)
    starts: list[np.ndarray] = []
    for i in np.argsort(norms):
        far = all(abs(seeds[i][CORE_PLUG] - s[CORE_PLUG])
                  + abs(seeds[i][CORE_LENGTH] - s[CORE_LENGTH]) >= 2.0 for s in starts)
        if far:
            starts.append(seeds[i])
        if len(starts) == n_starts:
            break
    fits = fork_map(lambda s: fit_bounded(fun, s, lo, hi, space, diff, MAX_NFEV_START), starts)
    return min(fits, key=lambda f: f.rss)


MAX_EMPTY_FRACTION = 0.8
"""Largest empty share of a partially filled hole ``fit_partial`` considers."""


def fit_partial(predict, diff: Differences, space: ParamSpace, sigma_rel: SigmaRel,
                full: ChangeFit, start_fraction: float = 0.4) -> ChangeFit:
    """Fit H1 with part of the hole possibly empty.

    H1 with one more parameter, the empty fraction e of the hole behind the plug (a
    partial fill: the fill at the bottom of the hole, x = core + [e]), started from the H1
    core at e = ``start_fraction`` with the fill ratio raised so that its hole-averaged
    ratio r (1 - e) is H1's.
    """
    fun = residual_function(predict, diff, space, sigma_rel)
    lo = np.append(space.lower(), 0.0)
    hi = np.append(space.upper(), MAX_EMPTY_FRACTION)
    plug, length, p, q = full.x[N_NULL:N_NULL + N_CORE]
    b = max(p + q, R_MAX * MIN_B) / R_MAX
    r = min(R_MAX * p / max(p + q, 1e-12) / (1.0 - start_fraction), R_MAX - 0.05)
    x0 = np.concatenate([full.x[:N_NULL], space.to_x(plug, length, b, r), [start_fraction]])
    return fit_bounded(fun, x0, lo, hi, space, diff, MAX_NFEV_CORE)


SHAPE_NOISE_FLOOR = 1e-3
"""Lowest relative shape noise used: the model error of the predicted shape changes (caliper
noise of the profile, mesh, calibration) is of this order, so with cleaner data than this the
F test would call that model error an alteration (measured: nearly noise-free unaltered bats
with a diagnose-calibrated reference gave F = 14 without the floor), and two identical tests
would have zero residual."""


def shape_noise_profile(phi: np.ndarray, floor_share: float) -> np.ndarray:
    """Return the shape-noise profile of each mode.

    (n_points, m) standard deviation of each shape entry relative to its mode's RMS
    noise: sqrt((phi^2 + k^2 rms^2) / ((1 + k^2) rms^2)), k = ``floor_share``, rms the
    mode's RMS over the points (mean square 1 over each mode's points). An FRF's random
    error is relative to |H|, and near a resonance |H_j| ~ |phi_j|; k is the floor near
    the nodes.
    """
    rms = np.sqrt(np.mean(phi**2, axis=0))
    k2 = floor_share**2
    return np.sqrt((phi**2 + k2 * rms**2) / ((1 + k2) * rms**2))


SHAPE_NOISE_PRIOR_POINTS = 2.0
"""Weight, in test points, of the modes' mean shape noise in each mode's estimate
(``shape_noise``), empirical Bayes: on 30 clean fleet bats ln s_r^2 varied between a bat's
modes by 1.42 (variance), of which the estimate's own scatter (2 / n for n points) is 0.15,
so the modes' true levels differ by 1.27 and the best shrinkage puts weight 0.15 / 1.42 on
the mean: n0 = n 0.15 / 1.27 ~ 1.7 points."""


def shape_noise(fit: ChangeFit, diff: Differences, sigma_rel: SigmaRel,
                n_params: int) -> np.ndarray:
    """Re-estimate each mode's relative shape noise.

    (m,) relative shape noise of each mode, re-estimated from a fit weighted with
    ``sigma_rel`` (its shape residual r[j, r], n points j, m modes r):

        s_r^2 = sigma_old_r^2 sum_j r[j,r]^2 / (n c),   c = 1 - p / N
        sigma_r^2 = (n s_r^2 + n0 mean_r(s_r^2)) / (n + n0)

    (the parameters' degrees of freedom shared in proportion to the data; each mode's
    variance shrunk towards the modes' mean as if n0 = ``SHAPE_NOISE_PRIOR_POINTS`` points of
    it were added), not below ``SHAPE_NOISE_FLOOR``. Modes are not measured equally well:
    on 30 clean fleet bats the null's residual variance per shape entry was 1.6 (median) for
    mode 1 against 0.3-0.5 for modes 2-4 under one common level, and a member of a badly
    merged plane pair (mode 6) reached 3-4; one level for all modes under-weighted the quiet
    ones and let one bad mode set every mode's noise.
    """
    r = fit.shape_residual
    n_points = r.shape[0]
    c = 1.0 - n_params / diff.n_data
    old = np.broadcast_to(np.asarray(sigma_rel, dtype=float), (r.shape[1],))
    s2 = old**2 * np.sum(r**2, axis=0) / (n_points * c)
    n0 = SHAPE_NOISE_PRIOR_POINTS
    shrunk = (n_points * s2 + n0 * np.mean(s2)) / (n_points + n0)
    return np.maximum(np.sqrt(shrunk), SHAPE_NOISE_FLOOR)


def covariance(fit: ChangeFit, dof: int) -> np.ndarray:
    """s^2 (J^T J)^+ with s^2 = RSS / dof (parameters in x units; ``updating.lsq``)."""
    return lsq_covariance(fit.jac, fit.residual, dof)
