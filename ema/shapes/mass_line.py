"""Scaling check against the bat's mass: the rigid-body (suspension) modes and the mass line.

A free-free bat hung on soft cords has two rigid-body modes in the transverse plane (bounce,
pitch). Together their mass-normalised shapes give the rigid-body flexibility

    G_jk = sum_s phi_js phi_ks = 1/M + (x_j - x_c)(x_k - x_c)/I = [1, x_j] C [1, x_k]^T,
    C = [[1/M + x_c^2/I, -x_c/I], [-x_c/I, 1/I]],

so M = C11 / det C, x_c = -C01 / C11, I = 1 / C11 (mass, centre of mass, pitch inertia about
it). Above the suspension modes each of them adds -w^2 phi phi / (w_s^2 - w^2) ~ phi phi to
the accelerance: G is also the *mass line*, the lower residual L0 of ``ema.shapes.lsfd``.

With the suspension modes fitted (band reaching below them) all of G is known and the
implied mass follows. From the lower residual of a roving-hammer test only one row of G is
known, a line a(x) = c0 + c1 x, and M is not identifiable from it alone: a(x_d) = 1/M +
(x_d - x_c)^2 / I >= 1/M bounds M from below, M >= 1 / a(x_d) (``mass_upper_bound_kg`` holds
that lower bound), and a known mass fixes x_c = (1/M - c0) / c1 and I = (x_d - x_c) / c1,
which must be plausible (x_c on the bat, I > 0). With one node (a single FRF) only the bound
is known.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RigidBody:
    """Rigid-body properties implied by the modal scaling (None where not identifiable)."""

    mass_kg: float | None
    x_cg_m: float | None
    pitch_inertia_kg_m2: float | None
    mass_upper_bound_kg: float | None = None


def rigid_body_from_modes(shapes: np.ndarray, x_m: np.ndarray) -> RigidBody:
    """Mass, centre of mass and pitch inertia from >= 2 mass-normalised rigid-body shapes (n, s)."""
    phi = np.asarray(shapes, dtype=float).reshape(np.shape(shapes)[0], -1)
    x = np.asarray(x_m, dtype=float)
    g = phi @ phi.T
    xj, xk = np.meshgrid(x, x, indexing="ij")
    a = np.stack([np.ones(g.size), (xj + xk).ravel(), (xj * xk).ravel()], axis=1)
    c00, c01, c11 = np.linalg.lstsq(a, g.ravel(), rcond=None)[0]
    det = c00 * c11 - c01**2
    if c11 <= 0 or det <= 0:
        return RigidBody(None, None, None)
    return RigidBody(float(c11 / det), float(-c01 / c11), float(1.0 / c11))


def rigid_body_from_mass_line(
    mass_line: np.ndarray, x_m: np.ndarray, x_drive_m: float, known_mass_kg: float | None = None
) -> RigidBody:
    """What one driving-point row of the mass line (1/kg at x_m) says about the rigid body."""
    a = np.asarray(mass_line, dtype=float)
    x = np.asarray(x_m, dtype=float)
    if np.unique(x).size < 2:  # one node (a single FRF): a(x_d) only, no slope
        a_d = float(np.mean(a))
        return RigidBody(None, None, None, float(1.0 / a_d) if a_d > 0 else None)
    c1, c0 = np.polyfit(x, a, 1)
    a_d = c0 + c1 * x_drive_m
    bound = float(1.0 / a_d) if a_d > 0 else None
    if known_mass_kg is None or c1 == 0:
        return RigidBody(None, None, None, bound)
    x_c = (1.0 / known_mass_kg - c0) / c1
    inertia = (x_drive_m - x_c) / c1
    return RigidBody(float(known_mass_kg), float(x_c), float(inertia), bound)
