"""The diagnosis model family: the paper's nominal bat model plus switchable physical extensions.

Nominal (docs/method.md): Euler-Bernoulli, isotropic, handbook E and density, ~1 in elements,
nothing attached. Each extension adds physics and at most one parameter:

    modulus             E                                fitted, parameter ln E
    density             rho = weight / wood volume        from the scale; fitted (ln rho) from
                                                          the mode-shape scale only when the
                                                          weight is unknown
    shear_deformation   Timoshenko beam, E/G             fitted, ln(E/G)
    rotary_inertia      rho I in the mass                no parameter (physics)
    sensor_mass         point mass at the driving point  fitted, grams
    suspension          two bungees 1 in from the ends   fitted, kN/m each
    geometry            finer mesh (0.5 in) with nodes   no parameter
                        at the test points
    shear_coefficient   Hutchinson's shear coefficient    no parameter (physics; a 3D solid
                        instead of Cowper's               agrees better, docs/model.md)
    two_planes          two bending planes: plane 2 has  fitted, ln(g_ratio) and theta;
                        E/G g_ratio times plane 1's, the  tried only when the test shows
                        tap at angle theta from plane 1   split pairs
    beam_theory         per-mode corrections f (1 + c_r)  no parameter; c_r from the 3D solid
                        measured against a 3D solid       (updating.solid; --solid)

Two planes: the model's modes are the union of each plane's (same E, density, sensor and
bungees; E/G and E/G g_ratio); a tap and a response along the angle theta see plane 1's mode
shapes times cos(theta) and plane 2's times sin(theta) (residue cos^2 / sin^2). Columns of
the solution: plane 1 scaled, plane 2 scaled, plane 1 unscaled (for a mode seen once, whose
measured shape carries the whole pair's amplitude), and the planes' mix (for a pair whose
split is below its peak's width, fitted as one mode: updating.diagnose.planes).

Modal sensitivities of mass-normalised modes with the full modal basis (Fox & Kapoor 1968;
exact for distinct eigenvalues):

    d lam_r = phi_r^T (K' - lam_r M') phi_r
    d phi_r = sum_{s != r} phi_s phi_s^T (K' - lam_r M') phi_r / (lam_r - lam_s)
              - 1/2 (phi_r^T M' phi_r) phi_r

with K' = K_structure (d/d ln E), -K_shear (d/d ln E/G, k_shear = kGA dK/dkGA),
M' = M_structure (d/d ln rho), n n^T / 1000 (d/d sensor grams, n the shape functions at the
sensor), 1000 sum n n^T (d/d bungee kN/m).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from updating.diagnose.planes import plane_mix
from updating.model.assembly import (
    BatModel,
    assemble,
    build_model,
    element_block,
    place,
    point_vector,
    scale_sections,
)
from updating.model.mass_properties import mass_properties
from updating.model.material import ISOTROPIC_E_OVER_G, Material
from updating.model.modes import solve_modes
from updating.model.profile import Profile
from updating.model.reference import BatReference
from updating.model.units import IN_TO_M

CAUSES = ("modulus", "density", "shear_deformation", "rotary_inertia", "sensor_mass",
          "suspension", "geometry", "shear_coefficient", "two_planes", "beam_theory")
FINE_ELEMENT_M = 0.5 * IN_TO_M
BUNGEE_FROM_END_M = IN_TO_M  # as BatReference places them


@dataclass(frozen=True)
class Setup:
    """What is known of one bat before any fit: profile, handbook wood, scale weight, test.

    Attributes
    ----------
    profile : Profile
        Caliper profile.
    handbook : Material
        The species' handbook material (E, rho; isotropic E/G).
    weight_kg : float | None
        The bat's weight on a scale (accelerometer not mounted), or None.
    points_m : np.ndarray
        Impact points from the knob end, m.
    sensor_x_m : float
        The accelerometer (driving point) position, m.
    fine_element_m : float
        Element length of the 'geometry' extension, m.
    solid_corrections : np.ndarray | None
        (k,) or (2, k) per-mode frequency corrections c_r of the 1D beam measured against a 3D
        solid (updating.solid.compare; a row per bending plane), or None ('beam_theory' not
        tried).
    density_factor : callable or None
        ``density_factor(x_m)``: the wood's density along the bat relative to uniform, at the
        same total mass (``build`` normalises it), or None: uniform. What a billet's
        gradient would do to the model (``updating.diagnose.sensor``); no fit uses it.
    """

    profile: Profile
    handbook: Material
    weight_kg: float | None
    points_m: np.ndarray
    sensor_x_m: float
    fine_element_m: float = FINE_ELEMENT_M
    solid_corrections: np.ndarray | None = None
    density_factor: Callable[[np.ndarray], np.ndarray] | None = None

    @cached_property
    def unit_mass(self):
        """Mass properties of the bat at unit density (updating.model.mass_properties)."""
        return mass_properties(build_model(self.profile, Material(1.0, 1.0)))

    @cached_property
    def rho_from_weight(self) -> float | None:
        """Mass density that makes the model weigh what the scale says: rho = W / int A dx."""
        if self.weight_kg is None:
            return None
        return self.weight_kg / self.unit_mass.mass_kg


@dataclass(frozen=True)
class State:
    """Physical parameter values of the model family (SI); inactive ones are ignored."""

    E_pa: float
    rho_kg_m3: float
    e_over_g: float = 10.0
    sensor_mass_kg: float = 1e-3
    bungee_k_n_per_m: float = 100.0
    g_ratio: float = 1.2
    theta_rad: float = 0.4


def free_parameters(active: frozenset[str], setup: Setup) -> tuple[str, ...]:
    """Names of the fitted parameters of a set of extensions, in a fixed order."""
    names = []
    if "modulus" in active:
        names.append("ln_E")
    if "density" in active and setup.weight_kg is None:
        names.append("ln_rho")
    if "shear_deformation" in active:
        names.append("ln_e_over_g")
    if "sensor_mass" in active:
        names.append("sensor_g")
    if "suspension" in active:
        names.append("bungee_kn_per_m")
    if "two_planes" in active:
        names += ["ln_g_ratio", "theta"]
    return tuple(names)


def to_vector(state: State, names: tuple[str, ...]) -> np.ndarray:
    """Return the values of the free parameters ``names`` of ``state``, in fit units.

    ln E, ln rho, ln E/G, sensor grams, bungee kN/m, ln g_ratio, theta (rad).
    """
    value = {"ln_E": np.log(state.E_pa), "ln_rho": np.log(state.rho_kg_m3),
             "ln_e_over_g": np.log(state.e_over_g), "sensor_g": 1e3 * state.sensor_mass_kg,
             "bungee_kn_per_m": 1e-3 * state.bungee_k_n_per_m,
             "ln_g_ratio": np.log(state.g_ratio), "theta": state.theta_rad}
    return np.array([value[n] for n in names])


def from_vector(state: State, names: tuple[str, ...], x: np.ndarray) -> State:
    """Return ``state`` with the free parameters ``names`` set from ``x`` (fit units)."""
    changes = {}
    for n, v in zip(names, x, strict=True):
        if n == "ln_E":
            changes["E_pa"] = float(np.exp(v))
        elif n == "ln_rho":
            changes["rho_kg_m3"] = float(np.exp(v))
        elif n == "ln_e_over_g":
            changes["e_over_g"] = float(np.exp(v))
        elif n == "sensor_g":
            changes["sensor_mass_kg"] = 1e-3 * float(v)
        elif n == "ln_g_ratio":
            changes["g_ratio"] = float(np.exp(v))
        elif n == "theta":
            changes["theta_rad"] = float(v)
        else:
            changes["bungee_k_n_per_m"] = 1e3 * float(v)
    return replace(state, **changes)


# physical ranges; E/G >= 2 = 2 (1 + nu) with nu >= 0 (the isotropic limit; wood: 9-20)
BOUNDS = {"ln_E": (np.log(1e8), np.log(1e11)), "ln_rho": (np.log(50.0), np.log(3000.0)),
          "ln_e_over_g": (np.log(2.0), np.log(60.0)), "sensor_g": (0.0, 100.0),
          "bungee_kn_per_m": (0.0, 100.0), "ln_g_ratio": (np.log(0.25), np.log(4.0)),
          "theta": (0.0, np.pi / 2)}


def effective_state(setup: Setup, active: frozenset[str], state: State) -> State:
    """Return the values the model of ``active`` really uses (nominal where an extension is off)."""
    hb = setup.handbook
    rho = hb.rho_kg_m3
    if "density" in active:
        rho = setup.rho_from_weight or state.rho_kg_m3
    return State(
        E_pa=state.E_pa if "modulus" in active else hb.E_pa,
        rho_kg_m3=rho,
        e_over_g=state.e_over_g if "shear_deformation" in active else ISOTROPIC_E_OVER_G,
        sensor_mass_kg=state.sensor_mass_kg if "sensor_mass" in active else 0.0,
        bungee_k_n_per_m=state.bungee_k_n_per_m if "suspension" in active else 0.0,
        g_ratio=state.g_ratio if "two_planes" in active else 1.0,
        theta_rad=state.theta_rad if "two_planes" in active else 0.0,
    )


def reference_of(setup: Setup, active: frozenset[str], state: State,
                 plane: int = 0) -> BatReference:
    """Build the calibrated reference (updating.model.reference) of a fitted model.

    ``plane`` 1: the model of the second bending plane (E/G times g_ratio).
    """
    s = effective_state(setup, active, state)
    shear = "shear_deformation" in active or "two_planes" in active
    two = "two_planes" in active
    corr = setup.solid_corrections if "beam_theory" in active else None
    return BatReference(
        E_pa=s.E_pa, rho_kg_m3=s.rho_kg_m3, nu=setup.handbook.nu,
        e_over_g=s.e_over_g * (s.g_ratio if plane == 1 else 1.0),
        beam="timoshenko" if shear else "euler", rotary_inertia="rotary_inertia" in active,
        sensor_mass_kg=s.sensor_mass_kg, sensor_x_m=setup.sensor_x_m,
        bungee_k_n_per_m=s.bungee_k_n_per_m,
        element_length_m=setup.fine_element_m if "geometry" in active else None,
        shear_coefficient="hutchinson" if "shear_coefficient" in active else "cowper",
        e_over_g_plane2=s.e_over_g * s.g_ratio if two else None,
        tap_angle_deg=float(np.degrees(s.theta_rad)) if two else None,
        beam_theory_corrections=None if corr is None else tuple(
            tuple(float(c) for c in row) for row in np.atleast_2d(corr)))


def build(setup: Setup, active: frozenset[str], state: State, plane: int = 0) -> BatModel:
    """Build the FE model of the extensions ``active`` with parameter values ``state``."""
    ref = reference_of(setup, active, state, plane)
    fine = "geometry" in active
    model = ref.build(setup.profile, stations_m=setup.points_m if fine else (),
                      element_length_m=setup.fine_element_m if fine else None)
    if setup.density_factor is None:
        return model
    x = model.node_x_m
    f = np.asarray(setup.density_factor((x[:-1] + x[1:]) / 2), dtype=float)
    s = model.samples
    m = np.bincount(s.elem, s.weight_m * s.props.rhoa, model.n_elements)
    f = f * m.sum() / (m @ f)  # the same wood's mass: the scale weighs the bat
    return scale_sections(model, rhoa=f, rhoi=f)


@dataclass(frozen=True)
class ModalSensitivities:
    """Modes of one model and their sensitivities to the free parameters.

    Attributes
    ----------
    elastic_hz : np.ndarray
        (k,) elastic frequencies (the two lowest modes, rigid or suspension, excluded), Hz.
    low_hz : np.ndarray
        (2,) the two lowest (suspension) frequencies, Hz; ~0 when free-free.
    shapes : np.ndarray
        (n_points, k) mass-normalised elastic shapes at the test points.
    dlnf : np.ndarray
        (p, k) d ln f / d parameter of the elastic modes.
    dlnf_low : np.ndarray
        (p, 2) the same for the two lowest modes.
    dshapes : np.ndarray
        (p, n_points, k) d shape / d parameter at the test points.
    n_planes : int
        2 for the two-plane model, whose columns are 4 k (module docstring).
    """

    elastic_hz: np.ndarray
    low_hz: np.ndarray
    shapes: np.ndarray
    dlnf: np.ndarray
    dlnf_low: np.ndarray
    dshapes: np.ndarray
    n_planes: int = 1


def rigid_flexibility(
    setup: Setup, active: frozenset[str], state: State, names: tuple[str, ...] = (),
) -> tuple[np.ndarray, np.ndarray]:
    """Compute the model's mass line at the test points and its derivatives (p, n_points).

    The rigid-body flexibility of the free bat with its accelerometer (mass m_s at x_s, the
    driving point), the driving point's row (ema.shapes.mass_line):

        G(x_j, x_s) = [1, x_j] R^-1 [1, x_s]^T,
        R = rho [[V, S], [S, J_0]] + m_s [[1, x_s], [x_s, x_s^2]],

    V = int A dx, S = int A x dx, J_0 = int (A x^2 + I) dx (the profile at unit density,
    rotary inertia counted: rigid-body physics, whatever the beam model), so R holds the mass,
    first moment and pitch inertia about the knob end. dG = -[1, x_j] R^-1 dR R^-1 [1, x_s]^T
    with dR / d sensor_g = 1e-3 [[1, x_s], [x_s, x_s^2]] and dR / d ln rho = the wood's part.
    E, E/G and the bungees do not enter: the mass line separates the accelerometer from E.
    This is ``updating.model.mass_properties.rigid_mass_line`` written with R, whose
    derivatives the calibration needs.
    """
    s = effective_state(setup, active, state)
    u = setup.unit_mass
    xs = setup.sensor_x_m
    wood = s.rho_kg_m3 * np.array([[u.mass_kg, u.mass_kg * u.cg_m],
                                   [u.mass_kg * u.cg_m, u.i_knob_kg_m2]])
    ts = np.array([1.0, xs])
    R = wood + s.sensor_mass_kg * np.outer(ts, ts)
    T = np.column_stack([np.ones(setup.points_m.size), setup.points_m])
    left = T @ np.linalg.inv(R)  # (n, 2)
    right = np.linalg.solve(R, ts)  # (2,)
    g = T @ right
    dg = np.zeros((len(names), g.size))
    for j, name in enumerate(names):
        if name == "sensor_g":
            dg[j] = -left @ (1e-3 * np.outer(ts, ts)) @ right
        elif name == "ln_rho":
            dg[j] = -left @ wood @ right
    return g, dg


def interpolation_matrix(model: BatModel, x_m: np.ndarray) -> np.ndarray:
    """Build the (P, n) matrix N with w(x_p) = N[p] @ dofs.

    The element shape functions N_w at each x (vectorised
    updating.model.assembly.displacement_at).
    """
    from updating.model.element import shape_functions

    x = np.asarray(x_m, dtype=float)
    e = np.clip(np.searchsorted(model.node_x_m, x, side="right") - 1, 0, model.n_elements - 1)
    L = model.element_length_m[e]
    n_w = shape_functions((x - model.node_x_m[e]) / L, L, model.phi[e]).n_w
    out = np.zeros((x.size, model.n_dof))
    out[np.arange(x.size)[:, None], model.dofs[e]] = n_w
    return out


def derivative_matrices(
    model: BatModel, names: tuple[str, ...], setup: Setup, plane: int = 0,
) -> list[tuple[np.ndarray | None, np.ndarray | None]]:
    """(dK, dM) per parameter name (None: zero) of the model of bending plane ``plane``."""
    out = []
    n = model.n_dof
    for name in names:
        if name == "theta" or (name == "ln_g_ratio" and plane == 0):
            out.append((None, None))
        elif name == "ln_g_ratio":
            out.append((-place(model, model.parts.k_shear), None))
        elif name == "ln_E":
            out.append((assemble(model, with_attachments=False)[0], None))
        elif name == "ln_rho":
            out.append((None, assemble(model, with_attachments=False)[1]))
        elif name == "ln_e_over_g":
            out.append((-place(model, model.parts.k_shear), None))
        elif name == "sensor_g":
            dofs, nw = point_vector(model, setup.sensor_x_m)
            dM = np.zeros((n, n))
            dM[element_block(dofs)] = 1e-3 * np.outer(nw, nw)
            out.append((None, dM))
        else:
            dK = np.zeros((n, n))
            for x in (BUNGEE_FROM_END_M, setup.profile.length_m - BUNGEE_FROM_END_M):
                dofs, nw = point_vector(model, x)
                dK[element_block(dofs)] += 1e3 * np.outer(nw, nw)
            out.append((dK, None))
    return out


def modal_sensitivities(
    setup: Setup, active: frozenset[str], state: State, n_elastic: int,
    names: tuple[str, ...] = (),
) -> ModalSensitivities:
    """Lowest ``n_elastic`` elastic modes of the model, with sensitivities to ``names``.

    With 'two_planes' the solution has 4 k columns (module docstring); with 'beam_theory'
    the frequencies carry the solid's corrections (1 + c_r), constant in the parameters.
    """
    one = solve_plane(setup, active, state, n_elastic, names, 0)
    k = one.elastic_hz.size
    factor = np.ones((2, k))
    if "beam_theory" in active and setup.solid_corrections is not None:
        c = np.atleast_2d(np.asarray(setup.solid_corrections, dtype=float))[:, :k]
        factor[:, :c.shape[1]] += c[[0, -1]]
    if "two_planes" not in active:
        return replace(one, elastic_hz=one.elastic_hz * factor[0])
    two = solve_plane(setup, active, state, n_elastic, names, 1)
    s = effective_state(setup, active, state)
    c, sn = np.cos(s.theta_rad), np.sin(s.theta_rad)
    j = names.index("theta") if "theta" in names else None
    drive = int(np.argmin(np.abs(setup.points_m - setup.sensor_x_m)))
    f1, f2 = one.elastic_hz * factor[0], two.elastic_hz * factor[1]
    mix = plane_mix((f1, f2), (one.shapes, two.shapes), (one.dlnf, two.dlnf),
                    (one.dshapes, two.dshapes), s.theta_rad, j, drive)
    shapes = np.hstack([c * one.shapes, sn * two.shapes, one.shapes, mix.shapes])
    dshapes = np.concatenate([c * one.dshapes, sn * two.dshapes, one.dshapes, mix.dshapes],
                             axis=2)
    if j is not None:
        dshapes[j, :, :3 * k] = np.hstack([-sn * one.shapes, c * two.shapes,
                                           np.zeros_like(one.shapes)])
    return ModalSensitivities(
        np.concatenate([f1, f2, f1, mix.freq_hz]), one.low_hz, shapes,
        np.hstack([one.dlnf, two.dlnf, one.dlnf, mix.dlnf]), one.dlnf_low, dshapes,
        n_planes=2)


def solve_plane(
    setup: Setup, active: frozenset[str], state: State, n_elastic: int,
    names: tuple[str, ...], plane: int,
) -> ModalSensitivities:
    """Solve the modes of one bending plane's model with their sensitivities."""
    model = build(setup, active, state, plane)
    K, M = assemble(model)
    modes = solve_modes(K, M)
    phi, lam = modes.shapes, modes.omega2
    k = min(n_elastic, model.n_dof - 2)
    sel = np.arange(2, 2 + k)
    low = np.arange(2)
    f = modes.freq_hz
    n_pts = interpolation_matrix(model, setup.points_m)
    p = len(names)
    dlnf = np.zeros((p, k))
    dlnf_low = np.zeros((p, 2))
    dshapes = np.zeros((p, n_pts.shape[0], k))
    for j, (dK, dM) in enumerate(derivative_matrices(model, names, setup, plane)):
        if dK is None and dM is None:
            continue
        A = phi.T @ dK @ phi if dK is not None else np.zeros_like(K)
        B = phi.T @ dM @ phi if dM is not None else np.zeros_like(K)
        dlam = np.diag(A) - lam * np.diag(B)
        with np.errstate(divide="ignore", invalid="ignore"):
            dlnf[j] = dlam[sel] / (2 * lam[sel])
            dlnf_low[j] = np.where(lam[low] > 0, dlam[low] / (2 * lam[low]), 0.0)
            gap = lam[sel][None, :] - lam[:, None]  # (n, k): lam_r - lam_s
            coef = (A[:, sel] - lam[sel][None, :] * B[:, sel]) / gap
        coef[sel, np.arange(k)] = -0.5 * np.diag(B)[sel]
        dshapes[j] = n_pts @ (phi @ coef)
    return ModalSensitivities(f[sel], f[low], n_pts @ phi[:, sel], dlnf, dlnf_low, dshapes)
