"""Both bending planes' modes as a fit that resolves every pair gives them (issue 38).

For fast tests and benchmarks of what the pairs' splits read
(``updating.inspect.plane_split``), without the FRF stage: each plane's truth model
(``VirtualBat.truth_model``), its elastic modes at the impact points weighted by the
plane's share of the measured response (shapes x sqrt(cos^2 theta) radial, sqrt(sin^2
theta) tangential), relative Gaussian noise ``freq_noise`` on every member's frequency
(stated as the fit's sd), then merged as the pipeline merges them
(``updating.correlate.planes.merge_plane_pairs``), so each pair keeps its members.
"""

from __future__ import annotations

import numpy as np

from updating.correlate.measured import MeasuredModes
from updating.correlate.planes import merge_plane_pairs
from updating.model.assembly import displacement_at
from updating.model.modes import model_modes
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
