"""The physical model of what can change between a baseline test and a re-test.

Relative to the bat's calibrated reference (``BatReference``):

- moisture and temperature: uniform factors on the wood's stiffness (E and G together) and
  density, ``K = s_E K_wood + K_bungees``, ``M = s_rho M_wood + M_sensor``;
- end-grain moisture: end grain takes up and gives off water many times faster than side
  grain, so the change near each end can be about twice the middle's. ``end_moisture_pt``
  (knob, barrel) adds m extra points there, decaying as w(x) = exp(-s / END_DECAY_M) with s
  the distance from that end, coupled as moisture is (about -2 % E and +1 % mass per point):
  ``K_wood -> K_wood - 0.02 m sum w_i k_i``, ``M_wood -> M_wood + 0.01 m sum w_i m_i``;
- the accelerometer re-mounted ``sensor_shift_m`` from where it was, and possibly a
  replacement of another mass (``sensor_mass_change_kg``);
- optionally an axial core (``Core``: depth, diameter, fill density ratio, fill modulus,
  plug), built exactly into the section properties (Cowper shear coefficient included).

``make_predictor`` returns a function of these parameters giving the paired elastic modes'
frequencies and mass-normalised shapes at the test points. Wood matrices are cached per core
so that changes of moisture or sensor position cost one eigen-solution only.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import solveh_banded

from updating.inspect.segments import Segment, segment_changes
from updating.model.assembly import (
    BatModel,
    assemble,
    attachment_matrices,
    element_at,
    element_block,
    place,
    point_vector,
    with_core,
    with_cores,
)
from updating.model.modes import rayleigh_freq_hz
from updating.model.profile import Profile
from updating.model.reference import BatReference
from updating.model.sections import Core
from updating.model.sensitivity import FullModes, full_modes


@dataclass(frozen=True)
class ChangeParams:
    """One state of the bat relative to its reference (see module docstring)."""

    stiffness_scale: float = 1.0
    density_scale: float = 1.0
    sensor_shift_m: float = 0.0
    core: Core | None = None
    end_moisture_pt: tuple[float, float] = (0.0, 0.0)
    sensor_mass_change_kg: float = 0.0
    segments: tuple[Segment, ...] = ()
    """Local changes (``segments.Segment``): a legal grip substance on the handle, or an
    alteration's added mass, lost diameter or generic change of mass and stiffness."""


END_DECAY_M = 2.0 * 0.0254
"""Decay length of the end-grain moisture excess (../docs/inspection.md)."""
E_PER_POINT, MASS_PER_POINT = -0.02, 0.01
"""Moisture coupling: relative change of E and of mass per point of moisture content."""


@dataclass(frozen=True)
class WoodSystem:
    """A bat without its accelerometer.

    The bat without its accelerometer: model, K_wood (+ bungees), M_wood, shape rows of
    the test points, and the end-grain weighted matrices (knob, barrel).
    """

    model: BatModel
    K: np.ndarray
    M: np.ndarray
    K_bungees: np.ndarray
    point_rows: np.ndarray
    K_ends: tuple[np.ndarray, np.ndarray]
    M_ends: tuple[np.ndarray, np.ndarray]
    translation: np.ndarray

    def wood_matrices(self, end_moisture_pt: tuple[float, float]) -> tuple[np.ndarray,
                                                                             np.ndarray]:
        """K_wood, M_wood with the end-grain moisture excess (module docstring)."""
        K, M = self.K, self.M
        for m, Ke, Me in zip(end_moisture_pt, self.K_ends, self.M_ends, strict=True):
            if m:
                K = K + E_PER_POINT * m * Ke
                M = M + MASS_PER_POINT * m * Me
        return K, M

    def mass_kg(self, end_moisture_pt: tuple[float, float]) -> float:
        """Return the wood's mass with the end-grain moisture excess, kg.

        t^T M_wood t with t the rigid translation, from its terms (``wood_matrices``):
        t^T M t + 0.01 sum m_i t^T M_end,i t, with no matrix formed.
        """
        t = self.translation
        mass = float(t @ self.M @ t)
        for m, Me in zip(end_moisture_pt, self.M_ends, strict=True):
            if m:
                mass += MASS_PER_POINT * m * float(t @ Me @ t)
        return mass


def wood_system(
    profile: Profile, reference: BatReference, points_m: np.ndarray, core: Core | None,
    like: WoodSystem | None = None, end_decay_m: float = END_DECAY_M,
) -> WoodSystem:
    """Model of the bat (wood only) with nodes at the test points, and its bungees.

    The end-grain moisture excess decays over ``end_decay_m`` from each end (module
    docstring). ``like``, the uncored system, gives a cored one its end-grain matrices and
    its model, rebuilt over the core alone (``assembly.with_core``, the same bit for bit).
    """
    if like is not None and core is not None:
        model = with_core(like.model, core)
    else:
        model = replace(reference, sensor_mass_kg=0.0).build(profile, points_m, core=core)
    return system_of(model, points_m, like, end_decay_m)


def cored_systems(like: WoodSystem, points_m: np.ndarray,
                  cores: tuple[Core, ...]) -> list[WoodSystem]:
    """Return ``wood_system`` of each core, their models integrated together.

    ``assembly.with_cores``: the cores of a Jacobian's steps in one pass.
    """
    return [system_of(model, points_m, like) for model in with_cores(like.model, cores)]


def system_of(model: BatModel, points_m: np.ndarray, like: WoodSystem | None,
              end_decay_m: float = END_DECAY_M) -> WoodSystem:
    """Return the wood system of a built model (``wood_system``)."""
    K, M = assemble(model, with_attachments=False)
    if like is not None and all(model.phi[e] == like.model.phi[e] for e in
                                (element_at(model, a.x_m) for a in model.attachments)):
        Kb = like.K_bungees  # the bungees' elements as they were: the same point vectors
    else:
        Kb, _ = attachment_matrices(model)
    idx = np.searchsorted(model.node_x_m, points_m - 1e-9)
    if np.any(np.abs(model.node_x_m[np.minimum(idx, model.n_nodes - 1)] - points_m) > 1e-9):
        raise ValueError("test points must be nodes of the model")
    t = np.zeros(model.n_dof)
    t[model.translational_dofs] = 1.0
    if like is not None:  # end-grain matrices of the uncored bat (a core is not at the grain)
        return WoodSystem(model, K, M, Kb, 2 * idx, like.K_ends, like.M_ends, t)
    mid = 0.5 * (model.node_x_m[:-1] + model.node_x_m[1:])
    parts = model.parts
    K_ends, M_ends = [], []
    for dist in (mid - model.node_x_m[0], model.node_x_m[-1] - mid):
        w = np.exp(-dist / end_decay_m)
        K_ends.append(place(model, parts.k_bend, w) + place(model, parts.k_shear, w))
        M_ends.append(place(model, parts.m_trans, w) + place(model, parts.m_rot, w))
    return WoodSystem(model, K, M, Kb, 2 * idx, tuple(K_ends), tuple(M_ends), t)


@dataclass(frozen=True)
class StateMatrices:
    """One state of the bat as the eigen-problem sees it.

    Attributes
    ----------
    K, M : numpy.ndarray
        (n_dof, n_dof) stiffness, N/m, and mass, kg, with the bungees and the accelerometer.
    dofs : numpy.ndarray
        (4,) the degrees of freedom of the element holding the accelerometer.
    n : numpy.ndarray
        (4,) its consistent point vector there (``assembly.point_vector``).
    point_rows : numpy.ndarray
        Rows of the test points' transverse displacements.
    sensor_mass_kg : float
        The accelerometer's mass in M (held off its limit when negative,
        ``ChangePredictor._sensor``), kg.
    """

    K: np.ndarray
    M: np.ndarray
    dofs: np.ndarray
    n: np.ndarray
    point_rows: np.ndarray
    sensor_mass_kg: float = 0.0

    def sensor_vector(self) -> np.ndarray:
        """Return the accelerometer's point vector over every degree of freedom, (n_dof,)."""
        v = np.zeros(self.K.shape[0])
        v[self.dofs] = self.n
        return v


LOCAL_CACHE = 64
"""Local-change matrices a predictor keeps (``ChangePredictor.local``)."""
SUM_CACHE = 8
"""Sums of several segments' changes a predictor keeps (``ChangePredictor.local``)."""
KEY_CACHE = 4096
"""Segments' cache keys and wood masses a predictor keeps (``ChangePredictor._local_key``,
``wood_mass_kg``): small entries, asked for at every state of a fit."""
STATE_CACHE = 4
"""States whose matrices and every mode a predictor keeps (``ChangePredictor.state``): about
0.5 MB each, asked for again by the Jacobian right after the residual."""
DERIVED_CACHE = 256
"""States whose modes or derivatives a predictor keeps (``ChangePredictor.derived``): a
refit evaluates some 20 states, and the next leave-out starts where the last one did (about
25 kB a Jacobian's derivatives)."""


class ChangePredictor:
    """predict(params) -> (freq_hz (n_solve,), shapes at the points (n_points, n_solve)).

    All of the lowest ``n_solve`` modes are returned (suspension modes included); the caller
    selects the elastic ones by index. ``sensor_x_m`` is the accelerometer's position before
    any shift. ``wood_mass_kg(params)`` is the bat's mass on a scale (no accelerometer).
    Wood systems are cached per core (at most 32).
    """

    def __init__(self, profile: Profile, reference: BatReference, points_m: np.ndarray,
                 sensor_x_m: float, n_solve: int, end_decay_m: float = END_DECAY_M):
        self.profile, self.reference = profile, reference
        self.end_decay_m = float(end_decay_m)
        self.points_m = np.asarray(points_m, dtype=float)
        self.sensor_x_m, self.n_solve = float(sensor_x_m), int(n_solve)
        self.drive = int(np.argmin(np.abs(self.points_m - self.sensor_x_m)))
        self._cache: dict[Core | None, WoodSystem] = {}
        self._local: dict = {}
        self._points: dict = {}
        self._woods: dict = {}
        self._masses: dict = {}
        self._keys: dict = {}
        self._sums: dict = {}
        self._derived: dict = {}
        self._states: dict = {}

    def at_sensor(self, sensor_x_m: float) -> ChangePredictor:
        """Return the same bat with its accelerometer elsewhere.

        The same bat with the accelerometer's unshifted position at ``sensor_x_m`` (the
        wood systems already built are shared).
        """
        out = ChangePredictor(self.profile, self.reference, self.points_m, sensor_x_m,
                              self.n_solve, self.end_decay_m)
        out._cache = self._cache
        out._local, out._sums = self._local, self._sums
        out._points = self._points
        out._woods, out._masses, out._keys = self._woods, self._masses, self._keys
        return out

    def with_reference(self, reference: BatReference) -> ChangePredictor:
        """Return the same points and sensor with another reference (no wood systems shared)."""
        return ChangePredictor(self.profile, reference, self.points_m, self.sensor_x_m,
                               self.n_solve, self.end_decay_m)

    def with_end_decay(self, end_decay_m: float) -> ChangePredictor:
        """Return the same bat whose end-grain moisture reaches ``end_decay_m`` from each end.

        No wood systems are shared (their end-grain matrices differ).
        """
        return ChangePredictor(self.profile, self.reference, self.points_m, self.sensor_x_m,
                               self.n_solve, end_decay_m)

    def system(self, core: Core | None = None) -> WoodSystem:
        """Return the wood's system, with ``core`` if given."""
        if core not in self._cache:
            if core is not None:
                self.systems((core,))
            else:
                self._cache[None] = wood_system(self.profile, self.reference, self.points_m,
                                                None, None, self.end_decay_m)
        return self._cache[core]

    def systems(self, cores) -> None:
        """Build the wood systems of the cores not built yet, together (``cored_systems``).

        At most 32 cored systems are kept: beyond, all but the uncored one are dropped.
        """
        missing = tuple(dict.fromkeys(c for c in cores if c not in self._cache))
        if not missing:
            return
        if len(self._cache) + len(missing) > 33:
            for key in [k for k in self._cache if k is not None]:
                del self._cache[key]
            for kept in (self._woods, self._masses, self._keys):  # keyed by a system's id:
                kept.clear()  # a new system may take a dropped one's id
        built = cored_systems(self.system(None), self.points_m, missing)
        self._cache.update(zip(missing, built, strict=True))

    def local(self, ws: WoodSystem, segments: tuple[Segment, ...]):
        """(dK, dM, mass change) of local changes on a wood system, or None for none.

        The sum of each segment's change, cached per segment and the shear parameters phi
        of the elements it covers, at most ``LOCAL_CACHE`` entries: the change depends on
        the system through those alone (``segments.segment_parts``; the wood, the mesh and
        the profile are the predictor's), so a core elsewhere on the bat leaves it. A fit's
        Jacobian moves one parameter at a time, so most of its columns share the segments,
        and a step of one segment, or of the core, leaves the other's. The sum of several
        segments is kept beside them (a Jacobian's segment steps each take the state's
        sum away again).
        """
        if not segments:
            return None
        keys = tuple(self._keep_local(ws, segments))
        if len(keys) == 1:
            return self._local[keys[0]]
        if keys not in self._sums:
            parts = [self._local[key] for key in keys]
            if len(self._sums) >= SUM_CACHE:
                del self._sums[next(iter(self._sums))]  # the oldest
            self._sums[keys] = (sum(p[0] for p in parts), sum(p[1] for p in parts),
                                sum(p[2] for p in parts))
        return self._sums[keys]

    def _keep_local(self, ws: WoodSystem, segments) -> list:
        """Return the cache keys of ``segments`` on ``ws``, integrating the missing ones.

        The missing ones are integrated together (``segments.segment_changes``); when they
        would overflow ``LOCAL_CACHE``, the cache is emptied first.
        """
        keys = [self._local_key(ws, seg) for seg in segments]
        missing = list(dict.fromkeys(k for k in keys if k not in self._local))
        if missing:
            if len(self._local) + len(missing) > LOCAL_CACHE:
                self._local.clear()
                missing = list(dict.fromkeys(keys))
            dK, dM, mass = segment_changes(ws.model, [k[0] for k in missing])
            for i, key in enumerate(missing):
                self._local[key] = (dK[i], dM[i], float(mass[i]))
        return keys

    def _local_key(self, ws: WoodSystem, seg: Segment) -> tuple:
        """Return the cache key of ``seg`` on ``ws``: the segment and the phi it covers.

        Kept per system and segment (a fit asks for the same few segments thousands of
        times); dropped with the systems (``systems``), as the wood's matrices and mass are.
        """
        at = (id(ws), seg)
        if at not in self._keys:
            if len(self._keys) >= KEY_CACHE:
                self._keys.clear()
            nodes, phi = ws.model.node_x_m, ws.model.phi
            self._keys[at] = (seg, phi[np.minimum(nodes[1:], seg.x1_m)
                                       > np.maximum(nodes[:-1], seg.x0_m)].tobytes())
        return self._keys[at]

    def wood_mass_kg(self, p: ChangeParams) -> float:
        """Return the wood's mass with the changes ``p``, kg.

        The segments' masses are summed alone (``local`` sums their matrices too, in the
        same order), and the wood's mass is kept per system and end-grain moisture.
        """
        ws = self.system(p.core)
        added = sum(self._local[key][2] for key in self._keep_local(ws, p.segments)) \
            if p.segments else 0.0
        key = (id(ws), p.end_moisture_pt)
        if key not in self._masses:
            if len(self._masses) >= KEY_CACHE:
                self._masses.clear()
            self._masses[key] = ws.mass_kg(p.end_moisture_pt)
        return p.density_scale * self._masses[key] + added

    def matrices(self, p: ChangeParams) -> StateMatrices:
        """Return K and M of the bat changed by ``p``, with its accelerometer, and where it is."""
        ws = self.system(p.core)
        K, M = self._wood(ws, p.end_moisture_pt)
        M = p.density_scale * M
        local = self.local(ws, p.segments)
        if local is not None:  # after moisture's scale: it scales the wood, not a foreign mass
            K, M = K + local[0], M + local[1]
        dofs, n, mass = self._sensor(ws, p, M)
        if mass:
            M[element_block(dofs)] += mass * np.outer(n, n)
        return StateMatrices(p.stiffness_scale * K + ws.K_bungees, M, dofs, n, ws.point_rows,
                             mass)

    def _sensor(self, ws: WoodSystem, p: ChangeParams,
                M: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, float]:
        """Return the accelerometer's (dofs, point vector n, mass in kg) in the state ``p``.

        The change may take the calibrated mass below 0 (calibration puts other physics
        there, the change is relative to it), but not so far that M + m n n^T stops being
        positive definite (m > -1 / n^T M^-1 n), where the eigen-solution would fail: a
        negative mass is kept above 0.9 times that limit, with M the state's matrix without
        the accelerometer (only read for a negative mass).
        """
        x = min(max(self.sensor_x_m + float(p.sensor_shift_m), 0.0), self.profile.length_m)
        dofs, n = self._point(ws, x)
        mass = self.reference.sensor_mass_kg + p.sensor_mass_change_kg
        if mass < 0:
            mass = max(mass, -0.9 / banded_inverse_form(M, dofs, n))
        return dofs, n, mass

    def matrix_steps(self, p: ChangeParams, base: StateMatrices,
                     steps: list[tuple[ChangeParams, float]]):
        """Return each step's difference quotients (dK, dM, dv), (k, N, N) twice and (k, N).

        ``(matrices(s) - matrices(p)) / h`` and the same of the accelerometer's point vector,
        for each step (s, h), computed from the terms the step changes: with
        K = s_E W + K_bungees, W = K_wood(e) + L_K and M = s_rho M_wood(e) + L_M + m n n^T
        (module docstring; L the segments' changes, e the end-grain moisture),

            K(s) - K(p) = (s_E' - s_E) W + s_E' (dK_wood + dL_K)
            M(s) - M(p) = (s_rho' - s_rho) M_wood + s_rho' dM_wood + dL_M + d(m n n^T)

        which is the same difference without assembling each stepped state (a Jacobian
        moves one parameter at a time). A step to another core is assembled and differenced.
        A step equal to ``p`` (a parameter the matrices do not hold) gives zeros.
        """
        n_dof, k = base.K.shape[0], len(steps)
        dK, dM, dv = np.zeros((k, n_dof, n_dof)), np.zeros((k, n_dof, n_dof)), \
            np.zeros((k, n_dof))
        self.systems(s.core for s, _ in steps if s.core != p.core)  # the steps' cores together
        ws = self.system(p.core)
        Kw, Mw = self._wood(ws, p.end_moisture_pt)
        # every segment the steps on this core hold, integrated together
        self._keep_local(ws, dict.fromkeys([*p.segments, *(seg for s, _ in steps
                                                            if s.core == p.core
                                                            for seg in s.segments)]))
        local = self.local(ws, p.segments)
        W = Kw if local is None else Kw + local[0]
        v0 = base.sensor_vector()
        for i, (s, h) in enumerate(steps):
            if s == p:
                continue
            if s.core != p.core:
                st = self.matrices(s)
                dK[i], dM[i] = (st.K - base.K) / h, (st.M - base.M) / h
                dv[i] = (st.sensor_vector() - v0) / h
                continue
            Ki, Mi = dK[i], dM[i]
            if s.stiffness_scale != p.stiffness_scale:
                Ki += (s.stiffness_scale - p.stiffness_scale) * W
            if s.density_scale != p.density_scale:
                Mi += (s.density_scale - p.density_scale) * Mw
            if s.end_moisture_pt != p.end_moisture_pt:
                for de, Ke, Me in zip(np.subtract(s.end_moisture_pt, p.end_moisture_pt),
                                      ws.K_ends, ws.M_ends, strict=True):
                    if de:
                        Ki += s.stiffness_scale * E_PER_POINT * de * Ke
                        Mi += s.density_scale * MASS_PER_POINT * de * Me
            if s.segments != p.segments:
                for sign, segs in ((1.0, s.segments), (-1.0, p.segments)):
                    part = self.local(ws, segs)
                    if part is not None:
                        Ki += sign * s.stiffness_scale * part[0]
                        Mi += sign * part[1]
            self._sensor_step(ws, p, s, base, Mi, dv[i])
            Ki /= h
            Mi /= h
            dv[i] /= h
        return dK, dM, dv

    def _sensor_step(self, ws: WoodSystem, p: ChangeParams, s: ChangeParams,
                     base: StateMatrices, Mi: np.ndarray, dvi: np.ndarray) -> None:
        """Add the accelerometer's change from ``p`` to ``s`` to Mi, and its point vector's to dvi.

        Mi holds M(s) - M(p) without the accelerometer on entry; ``base`` is the state ``p``
        (its accelerometer's mass included). A negative mass is held off its limit by the
        state's own matrix, so it is evaluated again whatever the step.
        """
        mass0 = base.sensor_mass_kg
        moved = s.sensor_shift_m != p.sensor_shift_m
        negative = self.reference.sensor_mass_kg + s.sensor_mass_change_kg < 0
        if not (moved or negative or s.sensor_mass_change_kg != p.sensor_mass_change_kg):
            return
        bare = None
        if negative:
            bare = base.M + Mi
            if mass0:
                bare[element_block(base.dofs)] -= mass0 * np.outer(base.n, base.n)
        dofs, n, mass = self._sensor(ws, s, bare)
        if mass:
            Mi[element_block(dofs)] += mass * np.outer(n, n)
        if mass0:
            Mi[element_block(base.dofs)] -= mass0 * np.outer(base.n, base.n)
        if moved:
            dvi[dofs] += n
            dvi[base.dofs] -= base.n

    def _wood(self, ws: WoodSystem, end_moisture_pt: tuple[float, float]):
        """Return ``ws.wood_matrices`` (the last few kept: a Jacobian's steps share them)."""
        key = (id(ws), end_moisture_pt)
        if key not in self._woods:
            if len(self._woods) >= LOCAL_CACHE:
                self._woods.clear()
            self._woods[key] = ws.wood_matrices(end_moisture_pt)
        return self._woods[key]

    def _point(self, ws: WoodSystem, x_m: float) -> tuple[np.ndarray, np.ndarray]:
        """Return ``point_vector`` of the accelerometer at ``x_m`` (the last few kept).

        Kept per position and the shear parameter phi of the element there, the one thing
        of the system the vector depends on besides the mesh (a core elsewhere leaves it).
        """
        key = (x_m, float(ws.model.phi[element_at(ws.model, x_m)]))
        if key not in self._points:
            if len(self._points) >= LOCAL_CACHE:
                self._points.clear()
            self._points[key] = point_vector(ws.model, x_m)
        return self._points[key]

    def observe(self, state: StateMatrices, shapes: np.ndarray) -> np.ndarray:
        """Return the mass-normalised mode ``shapes`` (n_dof, m) as the tests see them.

        The rows of the test points, times the accelerometer's driving-point factor
        (``driving_point_scale``).
        """
        at_points = shapes[state.point_rows]
        return at_points * driving_point_scale(state.n @ shapes[state.dofs],
                                               at_points[self.drive])

    def __call__(self, p: ChangeParams) -> tuple[np.ndarray, np.ndarray]:
        """Return the frequencies, Hz, and shapes at the points of the bat changed by ``p``.

        Read-only arrays, kept for the last few states (``derived``).
        """
        def solve() -> tuple[np.ndarray, np.ndarray]:
            state, modes = self.state(p)
            vec = modes.vectors[:, :self.n_solve]
            return rayleigh_freq_hz(state.K, state.M, vec), self.observe(state, vec)

        return self.derived(("modes", p), solve)

    def state(self, p: ChangeParams) -> tuple[StateMatrices, FullModes]:
        """Return the matrices of the bat changed by ``p`` and every mode of them.

        Kept for the last ``STATE_CACHE`` states: a fit asks for the Jacobian where it has
        just evaluated the residual (``sensitivity.predicted_change`` needs every mode, the
        residual the lowest ``n_solve``), so one eigen-solution of all modes serves both.
        """
        out = self._states.pop(p, None)
        if out is None:
            if len(self._states) >= STATE_CACHE:
                del self._states[next(iter(self._states))]  # the least recently used
            state = self.matrices(p)
            out = (state, full_modes(state.K, state.M))
        self._states[p] = out
        return out

    def derived(self, key, compute: Callable[[], tuple]) -> tuple:
        """Return ``compute()``, kept per ``key`` for the ``DERIVED_CACHE`` keys last used.

        What the predictor's states give (their modes, a Jacobian's derivatives) depends on
        the state alone, not on the data a fit weighs: the leave-one-out refits all start
        from the fit on all the data, and a refit with other noise levels from its end. The
        arrays of the tuple are made read-only, so that no caller changes a kept result.
        ``at_sensor`` starts a predictor with none kept (its accelerometer is elsewhere).
        """
        out = self._derived.pop(key, None)
        if out is None:
            if len(self._derived) >= DERIVED_CACHE:
                del self._derived[next(iter(self._derived))]  # the least recently used
            out = compute()
            for a in (out if isinstance(out, tuple) else vars(out).values()):
                if isinstance(a, np.ndarray):
                    a.flags.writeable = False
        self._derived[key] = out
        return out


def make_predictor(
    profile: Profile, reference: BatReference, points_m: np.ndarray, sensor_x_m: float,
    n_solve: int,
) -> ChangePredictor:
    """Build the bat's change predictor (``ChangePredictor``)."""
    return ChangePredictor(profile, reference, points_m, sensor_x_m, n_solve)


def driving_point_scale(at_sensor: np.ndarray, at_drive: np.ndarray) -> np.ndarray:
    """Return the baseline accelerometer's offset.

    Per-mode factor sqrt(phi(x_s) / phi(x_d)) that a roving-hammer test puts on the
    mass-normalised shapes when its accelerometer sits at x_s, off the driving point x_d.

    The fitter scales through the driving-point FRF, H(x_s, x_d), with modal constant
    phi(x_s) phi(x_d), taking it for phi(x_d)^2 (``ema.shapes.scaling``): its shape at point j,
    phi(x_s) phi(x_j) / sqrt(phi(x_s) phi(x_d)), is phi(x_j) times this factor. A sensor
    re-mounted 0.1 in away near the barrel end changes it by a few % at the higher modes.
    Ratios that are not positive (the sensor across a node) are clipped.
    """
    ratio = np.asarray(at_sensor, dtype=float) / np.where(at_drive != 0, at_drive, np.inf)
    return np.sqrt(np.clip(ratio, 1e-6, None))


def baseline_sensor_offset(
    predict: Callable[[ChangeParams], tuple[np.ndarray, np.ndarray]], freq_hz: np.ndarray,
    shapes: np.ndarray, max_offset_m: float = 0.25 * 0.0254, min_mac: float = 0.8,
) -> float:
    """Where the accelerometer sat at the baseline test, relative to its labelled point, m.

    The baseline's mass-normalised shapes carry the driving-point factor of the sensor's true
    position (``driving_point_scale``); the offset minimising sum ||(psi - phi(offset)) /
    rms(psi)||^2 over the paired elastic modes (reference model ``predict``, sensor mass
    moved with it) is returned (bounded scalar search within +-``max_offset_m``). The change
    fit then models a re-mounted sensor exactly instead of to first order.
    """
    from scipy.optimize import minimize_scalar

    from updating.correlate.pairing import align_signs, pair_modes

    f0, phi0 = predict(ChangeParams())
    elastic = np.flatnonzero(f0 >= 20.0)
    jb, jm, _ = pair_modes(shapes, phi0[:, elastic], freq_a_hz=freq_hz, freq_b_hz=f0[elastic],
                           min_mac=min_mac, max_rel_df=0.3)
    if jb.size == 0:
        return 0.0
    psi = shapes[:, jb]
    rms = np.sqrt(np.mean(psi**2, axis=0))

    def cost(offset_m: float) -> float:
        _, phi = predict(ChangeParams(sensor_shift_m=offset_m))
        return float(np.sum(((psi - align_signs(psi, phi[:, elastic[jm]])) / rms) ** 2))

    res = minimize_scalar(cost, bounds=(-max_offset_m, max_offset_m), method="bounded",
                          options={"xatol": 1e-5})
    return float(res.x)


def banded_inverse_form(M: np.ndarray, dofs: np.ndarray, n: np.ndarray,
                        bandwidth: int = 3) -> float:
    """Return v^T M^-1 v for v = n at ``dofs`` (zero elsewhere), M banded and positive definite.

    A beam's matrices couple a node's two DOFs with the next node's only, so M is banded
    (``bandwidth`` diagonals above the main one: 3). Cholesky in banded storage
    (``scipy.linalg.solveh_banded``) costs O(N b^2), against O(N^3) for a dense solve.
    """
    ab = np.zeros((bandwidth + 1, M.shape[0]))
    for k in range(bandwidth + 1):
        ab[bandwidth - k, k:] = np.diagonal(M, k)
    v = np.zeros(M.shape[0])
    v[dofs] = n
    return float(v @ solveh_banded(ab, v, check_finite=False))
