"""Free-free modes of the 3D solid: K u = w^2 M u with quadratic hexahedra (scikit-fem bases).

Element matrices are integrated here from scikit-fem's scalar Hex2 basis (values and gradients
at the Gauss points, weights dx = w |det J|), vectorised over elements:

    K_e = sum_q B_q^T D_q B_q dx_q,   M_e = rho sum_q N_q^T N_q dx_q (x I_3),

B the 6 x 81 strain-displacement matrix (Voigt, engineering shear), D the orthotropic
stiffness in global axes (updating.solid.elastic). Orientation of the material axes:
"planar" (growth rings as parallel planes across the billet: R along y, T along z; the two
bending planes differ, x-y bending shears in the L-R plane), or "cylindrical" (pith on the
axis: R radial, T tangential; both bending planes alike). Eigenpairs by shift-invert
Lanczos (scipy eigsh) about a small negative shift; the six rigid-body modes are dropped.
Each mode is classified by the motion of the nodes on the axis: bending in y or z
(transverse axis motion), longitudinal (axial), or torsion/other (the axis barely moves).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse
import scipy.sparse.linalg
from skfem import CellBasis, ElementHex2, MeshHex2

from updating.solid.elastic import OrthotropicWood, rotate_voigt


@dataclass(frozen=True)
class SolidModes:
    """Elastic modes of the solid, ascending.

    Attributes
    ----------
        freq_hz: (m,) all elastic frequencies found.
        kind: (m,) "bend_y", "bend_z", "axial" or "other".
        axis_x_m: (a,) positions of the axis nodes, sorted; axis_w: (a, m) the transverse
            displacement there in the mode's bending plane (y or z; 0 for other kinds).
        n_dof: size of the model.
        rigid: (mass kg, centre of mass m from the knob end, pitch inertia about it kg m^2)
            of the solid with its point masses, from the mass matrix (``rigid_body``), or
            None.
    """

    freq_hz: np.ndarray
    kind: np.ndarray
    axis_x_m: np.ndarray
    axis_w: np.ndarray
    n_dof: int
    rigid: tuple[float, float, float] | None = None

    def bending_hz(self, plane: str) -> np.ndarray:
        """Bending frequencies in plane "y" or "z", ascending."""
        return self.freq_hz[self.kind == f"bend_{plane}"]

    def one_plane(self) -> SolidModes:
        """Keep one mode of each degenerate pair of an axisymmetric solid.

        Both planes alike: one mode of each pair is labelled "bend_y", the other "other".
        """
        kind = self.kind.astype(object).copy()
        bend = np.flatnonzero(np.char.startswith(self.kind.astype(str), "bend"))
        kind[bend] = "other"
        kind[bend[::2]] = "bend_y"
        return SolidModes(self.freq_hz, kind.astype(str), self.axis_x_m, self.axis_w, self.n_dof,
                          self.rigid)


def material_axes(points: np.ndarray, orientation: str) -> np.ndarray:
    """(..., 3, 3) columns L, R, T in global components at points (3, ...)."""
    shape = points.shape[1:]
    R = np.zeros(shape + (3, 3))
    R[..., 0, 0] = 1.0
    if orientation == "planar":
        R[..., 1, 1] = 1.0
        R[..., 2, 2] = 1.0
    elif orientation == "cylindrical":
        phi = np.arctan2(points[2], points[1])
        R[..., 1, 1], R[..., 2, 1] = np.cos(phi), np.sin(phi)
        R[..., 1, 2], R[..., 2, 2] = -np.sin(phi), np.cos(phi)
    else:
        raise ValueError(f"unknown grain orientation {orientation!r} (planar or cylindrical)")
    return R


def strain_matrix(grad: np.ndarray) -> np.ndarray:
    """B (e, q, 6, 3n) from scalar gradients grad (e, q, n, 3); DOF order 3 a + i."""
    e, q, n, _ = grad.shape
    B = np.zeros((e, q, 6, n, 3))
    gx, gy, gz = grad[..., 0], grad[..., 1], grad[..., 2]
    B[:, :, 0, :, 0] = gx
    B[:, :, 1, :, 1] = gy
    B[:, :, 2, :, 2] = gz
    B[:, :, 3, :, 1], B[:, :, 3, :, 2] = gz, gy
    B[:, :, 4, :, 0], B[:, :, 4, :, 2] = gz, gx
    B[:, :, 5, :, 0], B[:, :, 5, :, 1] = gy, gx
    return B.reshape(e, q, 6, 3 * n)


def assemble_solid(mesh: MeshHex2, wood: OrthotropicWood, orientation: str = "planar",
                   density_factor: Callable[[np.ndarray], np.ndarray] | None = None):
    """(K, M) sparse CSR and the scalar basis (for node positions).

    ``density_factor(x_m)``: the density along the bat relative to ``wood``'s (a billet's
    gradient), at the Gauss points' x; None: uniform.
    """
    basis = CellBasis(mesh, ElementHex2(), intorder=4)
    n = len(basis.basis)
    grad = np.stack([basis.basis[a][0].grad for a in range(n)])  # (n, 3, e, q)
    grad = grad.transpose(2, 3, 0, 1)
    val = np.stack([np.asarray(basis.basis[a][0]) for a in range(n)]).transpose(1, 2, 0)
    dx = basis.dx  # (e, q)
    pts = basis.mapping.F(basis.quadrature[0])  # (3, e, q)
    D = rotate_voigt(wood.stiffness(), material_axes(pts, orientation))  # (e, q, 6, 6)
    B = strain_matrix(grad)
    DB = np.einsum("eqij,eqjk->eqik", D * dx[..., None, None], B)
    e = B.shape[0]
    Ke = np.matmul(B.reshape(e, -1, 3 * n).transpose(0, 2, 1), DB.reshape(e, -1, 3 * n))
    rho = wood.rho_kg_m3 * (1.0 if density_factor is None else density_factor(pts[0]))
    Me_s = np.einsum("eqa,eqb,eq->eab", val, val, rho * dx)
    Me = np.einsum("eab,ij->eaibj", Me_s, np.eye(3)).reshape(e, 3 * n, 3 * n)
    dofs = (3 * basis.element_dofs.T[:, :, None] + np.arange(3)[None, None, :]).reshape(e, -1)
    rows = np.broadcast_to(dofs[:, :, None], Ke.shape).ravel()
    cols = np.broadcast_to(dofs[:, None, :], Ke.shape).ravel()
    N = 3 * basis.N
    K = scipy.sparse.coo_matrix((Ke.ravel(), (rows, cols)), shape=(N, N)).tocsr()
    M = scipy.sparse.coo_matrix((Me.ravel(), (rows, cols)), shape=(N, N)).tocsr()
    return K, M, basis


def classify(u: np.ndarray, on_axis: np.ndarray) -> tuple[str, np.ndarray]:
    """(kind, transverse axis displacement) of one mode vector u (3N,)."""
    U = u.reshape(-1, 3)
    ax = U[on_axis]
    e = np.sum(ax**2, axis=0)
    if np.sqrt(np.max(np.sum(ax**2, axis=1))) < 0.05 * np.sqrt(np.max(np.sum(U**2, axis=1))):
        return "other", np.zeros(ax.shape[0])
    comp = int(np.argmax(e))
    kind = ("axial", "bend_y", "bend_z")[comp]
    return kind, (ax[:, comp] if comp else np.zeros(ax.shape[0]))


def rigid_body(M, doflocs: np.ndarray) -> tuple[float, float, float]:
    """Compute mass, x_cg and pitch inertia about the centre of mass in the x-y plane.

    From the mass matrix, with the rigid motions t (u_y = 1) and r (rotation about z through
    the origin: u_x = -y, u_y = x): m = t^T M t, m x_cg = t^T M r, I_0 = r^T M r,
    I_cg = I_0 - m x_cg^2 (point masses and the sections' own rotary inertia included).
    """
    n = doflocs.shape[1]
    t = np.zeros(3 * n)
    t[1::3] = 1.0
    r = np.zeros(3 * n)
    r[0::3], r[1::3] = -doflocs[1], doflocs[0]
    mass = float(t @ (M @ t))
    cg = float(t @ (M @ r)) / mass
    return mass, cg, float(r @ (M @ r)) - mass * cg**2


def solid_modes(
    mesh: MeshHex2, wood: OrthotropicWood, n_modes: int = 30, orientation: str = "planar",
    progress: bool = False, point_masses: tuple[tuple[float, float], ...] = (),
    density_factor: Callable[[np.ndarray], np.ndarray] | None = None,
) -> SolidModes:
    """Lowest elastic modes of the free-free solid (rigid-body modes dropped).

    ``point_masses``: (x_m, kg) lumped on the axis node nearest x (an accelerometer), in all
    three directions. ``density_factor``: as ``assemble_solid``'s.
    """
    def say(msg):
        if progress:
            print(f"solid: {msg}", file=sys.stderr, flush=True)

    say(f"{mesh.nelements} quadratic hexahedra, assembling ...")
    K, M, basis = assemble_solid(mesh, wood, orientation, density_factor)
    loc = basis.doflocs
    r = np.hypot(loc[1], loc[2])
    on_axis = np.flatnonzero(r < 1e-9 * max(np.ptp(loc[0]), 1e-12))
    on_axis = on_axis[np.argsort(loc[0, on_axis])]
    if point_masses:
        M = M.tolil()
        for x_m, kg in point_masses:
            a = on_axis[np.argmin(np.abs(loc[0, on_axis] - x_m))]
            for i in range(3):
                M[3 * a + i, 3 * a + i] += kg
        M = M.tocsr()
    say(f"{K.shape[0]} DOF; solving for {n_modes} modes ...")
    # shift well below the first elastic mode; the rigid-body modes sit at 0
    lam, vec = scipy.sparse.linalg.eigsh(K, k=n_modes + 6, M=M, sigma=-(2 * np.pi * 10.0) ** 2,
                                         which="LM")
    order = np.argsort(lam)
    lam, vec = lam[order], vec[:, order]
    f = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
    elastic = f > 1e-3 * f.max()
    f, vec = f[elastic], vec[:, elastic]
    kinds, ws = [], []
    for j in range(f.size):
        k, w = classify(vec[:, j], on_axis)
        kinds.append(k)
        ws.append(w)
    say(f"done: {int(np.sum(np.char.startswith(np.array(kinds), 'bend')))} bending modes "
        f"below {f.max():.0f} Hz")
    return SolidModes(f, np.array(kinds), loc[0, on_axis], np.array(ws).T, K.shape[0],
                      rigid_body(M, loc))
