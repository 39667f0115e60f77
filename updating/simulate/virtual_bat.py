"""A bat on the virtual rig: the 'truth' model behind a simulated roving-hammer test.

The truth is deliberately richer than batlab's default reference: Timoshenko beam with the
wood's E/G and rotary inertia, a finer mesh, an accelerometer's mass (possibly off its
labelled point), two bungees, modal damping rising with frequency, moisture drift and noise.
Moisture: one percentage point of moisture content changes E by about -2 % and mass by about
+1 % (docs/method.md, real bats).

Optional nuisances of a real bat: a ``WoodField`` (moisture varying along the bat,
temperature, billet gradients; ``updating.simulate.wood``), cavities besides the core (a
cupped end, the empty part of a partial fill; ``updating.simulate.cavities``), and two bending
planes. Wood's E along the grain is the same in every direction but its shear modulus is not
(radial plane E/G_LR, tangential plane E/G_LT), so each bending mode is a pair; hammer and
accelerometer at angle theta to the radial plane measure

    H = cos^2(theta) H_R + sin^2(theta) H_T,

each term from its own planar model (the projection of a force at theta on each plane, and of
each plane's motion back on the sensor's axis).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ema.io.frf_data import FrfTest
from rigs.modal_model import ModalModel
from rigs.virtual_test import add_noise, noise_coherence, simulate_frf
from updating.model.assembly import Attachment, Beam, build_model, displacement_at
from updating.model.local_change import LocalChange, apply_local_changes, change_stations_m
from updating.model.material import Material
from updating.model.modes import model_modes
from updating.model.profile import Profile
from updating.model.sections import Core
from updating.model.units import IN_TO_M
from updating.simulate.cavities import apply_cavities, cavity_stations_m
from updating.simulate.wood import WoodField, apply_wood_field

DEFAULT_FREQ_HZ = np.arange(0.0, 3200.0 + 0.25, 0.5)
SHAPE_NOISE_FLOOR = 0.3
"""``simulate_modes``' shape noise near a mode's nodes, as a share of its RMS: the median
floor of the FRF-level fleet's identified shapes (docs/inspection.md, shape noise)."""


def moisture_scales(moisture_pct: float) -> tuple[float, float]:
    """(stiffness, density) factors for a change of moisture content in percentage points."""
    return 1.0 - 0.02 * moisture_pct, 1.0 + 0.01 * moisture_pct


@dataclass(frozen=True)
class VirtualBat:
    """A physical bat and its test set-up.

    Attributes
    ----------
    profile, material
        The real bat (true E, density, E/G).
    points_m : np.ndarray
        Impact points from the knob end, m (node numbers 1..n in this order).
    sensor_index : int
        Which point carries the accelerometer (driving point); -1: nearest to 1 in from the
        barrel end.
    sensor_offset_m : float
        The accelerometer sits this far from its labelled point (re-mounting).
    sensor_mass_kg : float
        Accelerometer (and cable) mass.
    bungee_k_n_per_m : float
        Stiffness of each of the two bungees, 1 in from either end.
    beam : Beam
        Beam theory of the truth model.
    core : Core | None
        An alteration, or None.
    moisture_pct : float
        Moisture-content change since registration, percentage points.
    zeta1, zeta_exponent : float
        Damping ratio of mode r is zeta1 (f_r / f_1) ** zeta_exponent.
    rel_noise, floor_noise : float
        Measurement noise (see rigs.virtual_test.simulate_frf).
    n_averages : int or None
        Hits averaged per point: the test then carries the coherence its noise implies
        (``rigs.virtual_test.noise_coherence``) and says how many hits (``n_averages``);
        None: FRFs alone, as before.
    element_length_m : float
        Mesh of the truth model.
    wood : WoodField | None
        Modulus and density factors along the bat (moisture profile, temperature, billet), or
        None (uniform wood).
    cavities : tuple[Core, ...]
        Cavities besides ``core`` (``Core`` each; a cup has plug 0).
    e_over_g_t : float | None
        E/G of the tangential bending plane; None: one plane (``material``'s).
    theta_deg : float
        Angle of hammer and accelerometer to the radial plane, degrees.
    local_changes : tuple[LocalChange, ...]
        The rulebook's changes (``updating.simulate.rulebook``), applied last.
    """

    profile: Profile
    material: Material
    points_m: np.ndarray
    sensor_index: int = -1
    sensor_offset_m: float = 0.0
    sensor_mass_kg: float = 0.0
    bungee_k_n_per_m: float = 0.0
    beam: Beam = "timoshenko"
    core: Core | None = None
    moisture_pct: float = 0.0
    zeta1: float = 0.005
    zeta_exponent: float = 0.3
    rel_noise: float = 0.005
    floor_noise: float = 1e-3
    element_length_m: float = 0.5 * IN_TO_M
    wood: WoodField | None = None
    cavities: tuple[Core, ...] = ()
    e_over_g_t: float | None = None
    theta_deg: float = 0.0
    local_changes: tuple[LocalChange, ...] = ()
    n_averages: int | None = None

    def planes(self) -> tuple[tuple[str, float], ...]:
        """Return the (plane, weight) pairs of the measured FRF.

        cos^2 theta radial, sin^2 theta tangential; one plane when ``e_over_g_t`` is None.
        """
        if self.e_over_g_t is None:
            return (("radial", 1.0),)
        t = np.radians(self.theta_deg)
        return (("radial", float(np.cos(t) ** 2)), ("tangential", float(np.sin(t) ** 2)))

    def sensor_point(self) -> int:
        """Return the index of the point carrying the accelerometer.

        ``sensor_index``, or when it is -1 the point nearest to 1 in from the barrel end.
        """
        if self.sensor_index >= 0:
            return self.sensor_index
        target = self.profile.length_m - IN_TO_M
        return int(np.argmin(np.abs(np.asarray(self.points_m) - target)))

    def sensor_x_m(self) -> float:
        """Return where the accelerometer really sits, m.

        Its labelled point plus the offset, kept on the bat (a sensor on the end face cannot move
        past it).
        """
        x = float(np.asarray(self.points_m, dtype=float)[self.sensor_point()])
        return float(np.clip(x + self.sensor_offset_m, 0.0, self.profile.length_m))

    def truth_model(self, plane: str = "radial"):
        """Build the FE model of one bending plane that generates the data (with attachments)."""
        stiff, dens = moisture_scales(self.moisture_pct)
        material = self.material.scaled(stiff, dens)
        if plane == "tangential":
            if self.e_over_g_t is None:
                raise ValueError("a one-plane bat has no tangential plane")
            material = replace(material, e_over_g=self.e_over_g_t)
        elif plane != "radial":
            raise ValueError(f"unknown bending plane {plane!r}")
        points = np.asarray(self.points_m, dtype=float)
        sensor_x = self.sensor_x_m()
        attach = []
        if self.sensor_mass_kg:
            attach.append(Attachment(sensor_x, mass_kg=self.sensor_mass_kg))
        if self.bungee_k_n_per_m:
            for x in (IN_TO_M, self.profile.length_m - IN_TO_M):
                attach.append(Attachment(x, k_n_per_m=self.bungee_k_n_per_m))
        stations = np.concatenate([points, cavity_stations_m(self.cavities,
                                                             self.profile.length_m),
                                   change_stations_m(self.local_changes, self.profile.length_m)])
        model = build_model(self.profile, material, beam=self.beam,
                            element_length_m=self.element_length_m, stations_m=stations,
                            core=self.core, attachments=tuple(attach))
        model = apply_wood_field(apply_cavities(model, material, self.cavities), self.wood)
        return apply_local_changes(model, self.local_changes, plane)


def damping_ratios(freq_hz: np.ndarray, zeta1: float, exponent: float) -> np.ndarray:
    """Modal damping rising with frequency; suspension/rigid modes (< 20 Hz) get 3 %."""
    f = np.asarray(freq_hz, dtype=float)
    elastic = f >= 20.0
    z = np.full(f.shape, 0.03)
    if elastic.any():
        f1 = f[elastic][0]
        z[elastic] = zeta1 * (f[elastic] / f1) ** exponent
    return z


def modal_model(
    bat: VirtualBat, max_mode_hz: float = 12000.0, plane: str = "radial",
) -> tuple[ModalModel, np.ndarray]:
    """Compute the truth's modes below ``max_mode_hz`` at the impact points.

    Also the accelerometer's own shape row (1, m) at its true position (which may be off its
    labelled point).
    """
    model = bat.truth_model(plane)
    modes = model_modes(model, n_modes=min(model.n_dof, 60))
    keep = modes.freq_hz <= max_mode_hz
    shapes = modes.shapes[:, keep]
    f_modes = modes.freq_hz[keep]
    points = np.asarray(bat.points_m, dtype=float)
    sensor_x = bat.sensor_x_m()
    modal = ModalModel(f_modes, damping_ratios(f_modes, bat.zeta1, bat.zeta_exponent),
                       displacement_at(model, shapes, points), points)
    return modal, displacement_at(model, shapes, [sensor_x])


def simulate_test(
    bat: VirtualBat, freq_hz: np.ndarray = DEFAULT_FREQ_HZ, seed: int | None = None,
    max_mode_hz: float = 12000.0,
) -> FrfTest:
    """Simulate the roving-hammer, fixed-accelerometer test of ``bat``: one FRF per point.

    Both bending planes weighted by ``bat.planes()``, then the noise.
    """
    s = bat.sensor_point()
    points = np.asarray(bat.points_m, dtype=float)
    h = 0.0
    for plane, weight in bat.planes():
        if weight == 0.0:
            continue
        modal, sensor_shape = modal_model(bat, max_mode_hz, plane)
        h = h + weight * simulate_frf(modal, freq_hz, np.array([s]), np.arange(points.size),
                                      0.0, 0.0, resp_shapes=sensor_shape)
    coherence, meta = None, {"source": "batlab virtual rig", "seed": seed}
    if bat.n_averages is not None:
        coherence = noise_coherence(h, bat.rel_noise, bat.floor_noise, bat.n_averages)
        meta["n_averages"] = int(bat.n_averages)
    h = add_noise(h, bat.rel_noise, bat.floor_noise, seed)
    nodes = np.arange(1, points.size + 1)
    return FrfTest(
        freq_hz=np.asarray(freq_hz, dtype=float), frf=h, response_nodes=nodes[[s]],
        reference_nodes=nodes, node_x_m={int(n): float(x) for n, x in zip(nodes, points,
                                                                         strict=True)},
        coherence=coherence, meta=meta,
    )


def with_changes(bat: VirtualBat, **changes) -> VirtualBat:
    """Copy the set-up with some fields changed (a re-test weeks later, say)."""
    return replace(bat, **changes)


def simulate_modes(
    bat: VirtualBat, n_modes: int = 6, freq_noise: float = 5e-4,
    shape_noise: float | np.ndarray = 0.01, seed: int | None = None,
):
    """Modes as a good modal fit of ``bat``'s test would give them, without the FRF stage.

    The truth model's elastic modes at the impact points (the accelerometer's own mass and
    position included), mass-normalised, with relative Gaussian noise on frequencies and
    shape entries: ``shape_noise`` times sqrt((phi^2 + k^2 rms^2) / (1 + k^2)), an FRF's
    error relative to |H| with a floor near the nodes (k = ``SHAPE_NOISE_FLOOR``; the
    shape's RMS noise is ``shape_noise`` times its RMS; one level, or (n_modes,) one per
    mode). Scaled as the fitter scales them,
    through the driving-point FRF: an accelerometer off its labelled point multiplies each
    shape by sqrt(phi(sensor) / phi(driving point)) (``inspect.model.driving_point_scale``).
    For fast tests of the updating stage; the full path (simulate_test + ema fit) is the real
    thing.
    """
    from updating.correlate.measured import MeasuredModes
    from updating.inspect.hypotheses import shape_noise_profile
    from updating.inspect.model import driving_point_scale

    model = bat.truth_model()
    modes = model_modes(model, n_modes=min(model.n_dof, n_modes + 4))
    elastic = np.flatnonzero(modes.freq_hz >= 20.0)[:n_modes]
    points = np.asarray(bat.points_m, dtype=float)
    shapes = displacement_at(model, modes.shapes[:, elastic], points)
    s = bat.sensor_point()
    at_sensor = displacement_at(model, modes.shapes[:, elastic], [bat.sensor_x_m()])
    shapes = shapes * driving_point_scale(at_sensor[0], shapes[s])
    rng = np.random.default_rng(seed)
    f = modes.freq_hz[elastic] * (1 + freq_noise * rng.standard_normal(elastic.size))
    rms = np.sqrt(np.mean(shapes**2, axis=0))
    sd = np.asarray(shape_noise) * rms * shape_noise_profile(shapes, SHAPE_NOISE_FLOOR)
    shapes = shapes + sd * rng.standard_normal(shapes.shape)
    zeta = damping_ratios(modes.freq_hz[elastic], bat.zeta1, bat.zeta_exponent)
    return MeasuredModes(f, shapes, points, zeta, float(points[s]),
                         freq_noise * f)
