"""Test points for a bat: the barrel covered where a core could be, the rest by EfI.

Effective independence (EfI; Kammer 1991, J. Guid. Control Dyn.): candidates are
translational DOFs; with target shapes Phi (c x m) the values
E_D = diag(Phi (Phi^T Phi)^-1 Phi^T) measure each candidate's share of the Fisher information;
the candidate with the smallest E_D is removed until ``n_points`` remain. Candidates that
must stay (``keep``) are never removed.

EfI alone puts the points where the first bending modes are most independent and, on a bat,
leaves the barrel bare (nothing between 16 and 34 in on a 34 in bat) -- exactly where an
alteration lives (a core drilled from the barrel end, up to ~12 in deep behind a ~1 in plug).
So ``suggest_points`` first lays a fixed row along the last ``BARREL_ZONE_IN`` inches: the
driving point (accelerometer) 1.5 in from the barrel end, not on the end face (a cupped end
has no flat face, and a sensor there sees the plug, not the bat), then every 1.5 in towards
the knob (2, 2.5 or 3 in when the points are few: 11 or more points give 2 in or less); EfI
chooses the remaining points on the handle and taper from the model's first four bending
modes, among candidates 1.5 in apart (EfI alone clusters points in pairs at antinodes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.model.units import IN_TO_M

BARREL_ZONE_IN = 14.0
"""Length covered at the barrel end: the deepest core (12 in) behind its plug, and a margin."""
DRIVING_POINT_FROM_END_IN = 1.5
"""The accelerometer (driving point) this far from the barrel end."""
BARREL_SPACINGS_IN = (1.5, 2.0, 2.5, 3.0)
"""Spacing of the barrel row, the first that leaves at least ``MIN_FREE_POINTS`` for EfI."""
MIN_FREE_POINTS = 3
FREE_GRID_IN = 1.5
"""Spacing of the candidates for the free points (handle and taper)."""
END_MARGIN_IN = 1.0
"""No free point closer than this to the knob end (the knob's end face is not tapped)."""


def effective_independence(shapes: np.ndarray, n_points: int, keep=()) -> np.ndarray:
    """Choose the ``n_points`` rows of ``shapes`` (c x m) Effective Independence keeps.

    Rows in ``keep`` are never removed. Returns their indices, ascending.
    """
    phi = np.asarray(shapes, dtype=float)
    if n_points < phi.shape[1]:
        raise ValueError("need at least as many points as target modes")
    fixed = set(int(k) for k in keep)
    if len(fixed) > n_points:
        raise ValueError("more fixed points than points asked for")
    rows = np.arange(phi.shape[0])
    while rows.size > n_points:
        p = phi[rows]
        ed = np.einsum("ij,ij->i", p @ np.linalg.pinv(p.T @ p), p)
        ed[[i for i, r in enumerate(rows) if r in fixed]] = np.inf
        rows = np.delete(rows, int(np.argmin(ed)))
    return rows


@dataclass(frozen=True)
class PointLayout:
    """Suggested impact points (ascending, m from the knob end) and the driving point."""

    points_m: np.ndarray
    driving_point_m: float


def barrel_row_in(length_in: float, spacing_in: float) -> np.ndarray:
    """Return the fixed barrel row, in (ascending).

    From the driving point towards the knob every ``spacing_in``, over the last
    BARREL_ZONE_IN inches.
    """
    start = length_in - DRIVING_POINT_FROM_END_IN
    n = int(np.floor((BARREL_ZONE_IN - DRIVING_POINT_FROM_END_IN) / spacing_in + 1e-9)) + 1
    return np.sort(np.round(start - spacing_in * np.arange(n), 2))


def suggest_points(
    length_m: float, shapes_at, n_points: int = 16, n_modes: int = 4,
) -> PointLayout:
    """``n_points`` test points for a bat ``length_m`` long.

    Parameters
    ----------
    length_m : float
        Bat length.
    shapes_at
        Callable x_m (k,) -> (k, m) transverse displacements of the target (elastic) modes
        there, e.g. ``lambda x: displacement_at(model, shapes, x)``.
    n_points : int
        Number of points, at least a barrel row plus MIN_FREE_POINTS.
    n_modes : int
        How many target modes EfI uses for the free points.
    """
    length_in = length_m / IN_TO_M
    for spacing in BARREL_SPACINGS_IN:
        row = barrel_row_in(length_in, spacing)
        if n_points - row.size >= MIN_FREE_POINTS:
            break
    else:
        raise ValueError(f"--n-points {n_points}: at least {row.size + MIN_FREE_POINTS} points "
                         "are needed to cover the barrel")
    cand = np.round(np.arange(END_MARGIN_IN, row[0] - FREE_GRID_IN + 1e-9, FREE_GRID_IN), 2)
    all_in = np.concatenate([row, cand])
    phi = np.asarray(shapes_at(all_in * IN_TO_M))[:, :n_modes]
    keep = effective_independence(phi, n_points, keep=range(row.size))
    points_in = np.sort(all_in[keep])
    return PointLayout(points_in * IN_TO_M, float(row[-1] * IN_TO_M))
