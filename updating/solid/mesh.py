"""Hexahedral mesh of a solid of revolution from the bat's profile (O-grid cross-section).

Cross-section: an inner square block of n x n cells and four ring blocks of n tangential by
m radial cells, built straight-edged in a reference square [-1, 1]^2 (inner square |p|_inf <=
c = 0.5) and mapped to the unit disc. In the ring sector x >= |y| (the others by rotation),
with sigma = x and tau = y / x:

    alpha = tau pi/4,  inner P_i = c (1, tan alpha),  outer P_o = (cos alpha, sin alpha),
    q = P_i + (sigma - c) / (1 - c) (P_o - P_i);

the inner square maps as (a, b) -> c (tan(a pi / 4c), tan(b pi / 4c)) to match. The map is
smooth inside every cell, so applying it to all 27 nodes of the quadratic (Hex2) mesh gives
isoparametric elements with curved faces on the circle, equally spaced in angle.
The section is then scaled by the profile's radius R(x); axial nodes
lie on every profile station so R is linear inside each element and the mapping exact.
A step (two stations at one x) becomes a linear transition over ``step_m`` (a hexahedral mesh
of revolution cannot carry a re-entrant corner): the 3D model of a stepped bat is that of a
bat with steep short tapers there.
"""

from __future__ import annotations

import numpy as np
from skfem import MeshHex, MeshHex2

from updating.model.profile import Profile

INNER = 0.5


def _block(s: np.ndarray, t: np.ndarray, z: np.ndarray, f) -> tuple[np.ndarray, np.ndarray]:
    """(points, cells) of a tensor block in (s, t, z) mapped in-plane by f."""
    m = MeshHex.init_tensor(s, t, z)
    x, y = f(m.p[0], m.p[1])
    return np.vstack([x, y, m.p[2]]), m.t


def reference_section_mesh(n: int, m: int, z: np.ndarray) -> MeshHex:
    """Linear hexahedra of the straight-edged reference O-grid, extruded along z (axial)."""
    tau = np.linspace(-1.0, 1.0, n + 1)
    sig = np.linspace(INNER, 1.0, m + 1)
    c = INNER
    blocks = [_block(c * tau, c * tau, z, lambda a, b: (a, b))]
    for rot in range(4):
        ca, sa = np.cos(rot * np.pi / 2), np.sin(rot * np.pi / 2)

        def f(s, t, ca=ca, sa=sa):
            x, y = s, s * t
            return ca * x - sa * y, sa * x + ca * y

        blocks.append(_block(sig, tau, z, f))
    offsets = np.cumsum([0] + [p.shape[1] for p, _ in blocks])
    p = np.hstack([p for p, _ in blocks])
    t = np.hstack([t + o for (_, t), o in zip(blocks, offsets[:-1], strict=True)])
    _, first, inverse = np.unique(np.round(p.T, 9), axis=0, return_index=True,
                                  return_inverse=True)
    return MeshHex(np.ascontiguousarray(p[:, first]),
                   np.ascontiguousarray(inverse.ravel()[t]))


def disc_map(y: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Map the reference square to the unit disc (module docstring)."""
    c = INNER
    out_y = c * np.tan(y * np.pi / (4 * c))
    out_z = c * np.tan(z * np.pi / (4 * c))
    ring = np.maximum(np.abs(y), np.abs(z)) > c + 1e-12
    for rot in range(4):
        ca, sa = np.cos(rot * np.pi / 2), np.sin(rot * np.pi / 2)
        sig, v = ca * y + sa * z, -sa * y + ca * z  # local sector coordinates
        sel = ring & (sig >= np.abs(v) - 1e-12) & (sig > 0)
        if not np.any(sel):
            continue
        alpha = v[sel] / sig[sel] * np.pi / 4
        t = (sig[sel] - c) / (1 - c)
        qy = c + t * (np.cos(alpha) - c)
        qz = c * np.tan(alpha) + t * (np.sin(alpha) - c * np.tan(alpha))
        out_y[sel] = ca * qy - sa * qz
        out_z[sel] = sa * qy + ca * qz
    return out_y, out_z


def axial_nodes(profile: Profile, n_axial: int, step_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Return the axial element boundaries and the radius there.

    Boundaries fall at every station; steps become tapers over step_m.
    """
    x = profile.x_m.astype(float).copy()
    r = profile.diameter_m / 2
    for i in np.flatnonzero(np.diff(x) == 0):
        x[i + 1] = x[i] + step_m
        if i + 2 < x.size and x[i + 2] <= x[i + 1]:
            raise ValueError("profile: a step lies closer than step_m to the next station")
    grid = np.linspace(0.0, x[-1], n_axial + 1)
    h = x[-1] / n_axial
    near = np.min(np.abs(grid[:, None] - x[None, :]), axis=1) < 0.3 * h
    nodes = np.unique(np.concatenate([grid[~near], x]))
    return nodes, np.interp(nodes, x, r)


def bat_mesh(profile: Profile, n_axial: int = 40, n_section: int = 2, n_ring: int = 1,
             step_m: float = 0.0025) -> MeshHex2:
    """Quadratic (27-node) hexahedral mesh of the bat: x along the axis from the knob end.

    Parameters
    ----------
    n_axial : int
        About this many elements along the bat (plus nodes at the stations).
    n_section : int
        Cells per side of the inner square (the section has n^2 + 4 n m cells).
    n_ring : int
        Radial cells in the ring.
    step_m : float
        Length of the transition replacing a step, m.
    """
    if n_axial < 1 or n_section < 1 or n_ring < 1:
        raise ValueError("mesh divisions must be at least 1")
    xs, rs = axial_nodes(profile, n_axial, step_m)
    ref = reference_section_mesh(n_section, n_ring, np.arange(xs.size, dtype=float))
    quad = MeshHex2.from_mesh(ref)
    p = quad.p
    y, z = disc_map(p[0], p[1])
    # axial: the reference coordinate k + u (u in [0, 1]) is element k; R linear in it
    k = np.clip(np.floor(p[2]).astype(int), 0, xs.size - 2)
    u = p[2] - k
    x = xs[k] + u * (xs[k + 1] - xs[k])
    r = rs[k] + u * (rs[k + 1] - rs[k])
    return MeshHex2(np.ascontiguousarray(np.vstack([x, r * y, r * z])),
                    np.ascontiguousarray(quad.t))
