"""Both bending planes' modes as a fit that resolves every pair gives them (issue 38).

For fast tests and benchmarks of what the pairs' splits read
(``updating.inspect.plane_split``), without the FRF stage: each plane's truth model
(``VirtualBat.truth_model``), its elastic modes at the impact points weighted by the
plane's share of the measured response (shapes x sqrt(cos^2 theta) radial, sqrt(sin^2
theta) tangential), relative Gaussian noise ``freq_noise`` on every member's frequency
(stated as the fit's sd), then merged as the pipeline merges them
(``updating.correlate.planes.merge_plane_pairs``), so each pair keeps its members.

``planes_case`` draws a nuisance-rich field bat (``field_fleet.draw_case``: moisture and
its uneven profile, temperature, billet, accelerometer, bungees, cup, and the rulebook's
change of its kind), both tests tapped 30-60 deg from the radial plane (both members show),
each plane's E/G moved by up to ``plane_split.RATIO_DRIFT`` between the tests, an optional
flat added, and a reference as calibration gives it (E within 1 %, density 0.5 %, E/G 10 %).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from updating.correlate.measured import MeasuredModes
from updating.correlate.planes import merge_plane_pairs
from updating.inspect.plane_split import RATIO_DRIFT
from updating.model.assembly import displacement_at
from updating.model.local_change import LocalChange
from updating.model.modes import model_modes
from updating.model.reference import BatReference
from updating.simulate.field_fleet import FieldCase, draw_case
from updating.simulate.virtual_bat import VirtualBat, damping_ratios


def simulate_pair_modes(bat: VirtualBat, n_modes: int = 6, freq_noise: float = 3e-5,
                        seed: int | None = None) -> MeasuredModes:
    """Return the two planes' first ``n_modes`` bending pairs, merged, with their members.

    Parameters
    ----------
    bat : VirtualBat
        A two-plane bat (``e_over_g_t`` set), tapped at ``theta_deg``.
    n_modes : int
        Bending modes per plane.
    freq_noise : float
        Relative sd of every member's frequency (also returned as ``freq_std_hz``).
    seed : int or None
        The noise's seed.

    Returns
    -------
    MeasuredModes
        The merged modes (``plane_pair_hz``: each pair's members, lower and upper).
    """
    if bat.e_over_g_t is None:
        raise ValueError("a one-plane bat has no pairs")
    rng = np.random.default_rng(seed)
    points = np.asarray(bat.points_m, dtype=float)
    freqs, shapes = [], []
    for plane, weight in bat.planes():
        model = bat.truth_model(plane)
        modes = model_modes(model, n_modes=min(model.n_dof, n_modes + 4))
        elastic = np.flatnonzero(modes.freq_hz >= 20.0)[:n_modes]
        freqs.append(modes.freq_hz[elastic])
        shapes.append(np.sqrt(weight) * displacement_at(model, modes.shapes[:, elastic],
                                                        points))
    f = np.concatenate(freqs) * (1 + freq_noise * rng.standard_normal(2 * n_modes))
    order = np.argsort(f)
    f, psi = f[order], np.column_stack(shapes)[:, order]
    zeta = damping_ratios(f, bat.zeta1, bat.zeta_exponent)
    s = bat.sensor_point()
    return merge_plane_pairs(MeasuredModes(f, psi, points, zeta, float(points[s]),
                                           freq_noise * f))


@dataclass(frozen=True)
class PlanesCase:
    """A field bat's two tests as merged pairs, and its calibrated reference."""

    case: FieldCase
    reference: BatReference
    baseline: MeasuredModes
    retest: MeasuredModes


def planes_case(seed: int, kind: str = "none", flat: LocalChange | None = None,
                freq_noise: float = 3e-5, n_modes: int = 6) -> PlanesCase:
    """Draw a two-plane field bat and its tests (module docstring).

    Parameters
    ----------
    seed : int
        ``draw_case``'s seed (its other draws from ``seed + 1000``).
    kind : str
        ``draw_case``'s kind ("none", a legal grip, ...).
    flat : LocalChange or None
        A change added to the re-test (a flat).
    freq_noise, n_modes : float, int
        ``simulate_pair_modes``'s.

    Returns
    -------
    PlanesCase
        The case (its re-test with the drift and the flat), reference and merged modes.
    """
    rng = np.random.default_rng(1000 + seed)
    case = draw_case(np.random.default_rng(seed), kind)
    base = replace(case.baseline, theta_deg=rng.uniform(30, 60))
    re = case.retest
    drift = 1 + rng.uniform(-RATIO_DRIFT, RATIO_DRIFT, 2)
    re = replace(re, theta_deg=rng.uniform(30, 60), e_over_g_t=re.e_over_g_t * drift[0],
                 material=replace(re.material, e_over_g=re.material.e_over_g * drift[1]),
                 local_changes=re.local_changes + ((flat,) if flat else ()))
    w, u = base.material, rng.uniform(-1, 1, 3)
    reference = BatReference(w.E_pa * (1 + 0.01 * u[0]), w.rho_kg_m3 * (1 + 0.005 * u[1]),
                             w.e_over_g * (1 + 0.1 * u[2]), beam="timoshenko",
                             rotary_inertia=True, sensor_mass_kg=base.sensor_mass_kg,
                             sensor_x_m=base.sensor_x_m(),
                             bungee_k_n_per_m=base.bungee_k_n_per_m)
    return PlanesCase(replace(case, baseline=base, retest=re), reference,
                      simulate_pair_modes(base, n_modes, freq_noise, seed=2 * seed),
                      simulate_pair_modes(re, n_modes, freq_noise, seed=2 * seed + 1))
