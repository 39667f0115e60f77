"""The bat's finite-element reference model: mesh, section quadrature, element parts, assembly.

Planar beam along x, two DOFs per node (transverse displacement w, rotation theta), node i
owns DOFs (2i, 2i+1); element i joins nodes i and i+1, so its connectivity c_i is the DOF
slice 2i..2i+3 and its global matrices are the 4x4 parts placed there (docs/method.md).
Section properties are integrated over each element by Gauss quadrature on every linear
piece of the profile that the element overlaps (steps included exactly).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from updating.model.element import ElementParts, displacement_shape, element_parts
from updating.model.material import Material
from updating.model.profile import Profile
from updating.model.sections import Core, SectionProps, section_props
from updating.model.units import IN_TO_M

Beam = Literal["euler", "timoshenko"]
"""Beam theory of the elements: Euler-Bernoulli, or Timoshenko (shear deformation)."""

GAUSS_POINTS = 6  # exact for the degree-10 integrands of a linearly tapered section


@dataclass(frozen=True)
class Attachment:
    """Something attached at x: a point mass (accelerometer) and/or a spring to ground (bungee)."""

    x_m: float
    mass_kg: float = 0.0
    k_n_per_m: float = 0.0


@dataclass(frozen=True)
class Samples:
    """Quadrature samples along the bat: where, with which weight, and the section there."""

    elem: np.ndarray  # (P,) element index
    xi: np.ndarray  # (P,) local coordinate 0..1
    weight_m: np.ndarray  # (P,) Gauss weight, m
    x_m: np.ndarray  # (P,) position from the knob end, m
    props: SectionProps


@dataclass(frozen=True)
class BatModel:
    """A meshed bat with its element matrices kept in separate physical parts.

    ``parts`` hold each element's 4x4 matrices (e, 4, 4); ``dofs`` (e, 4) their global DOFs.
    """

    node_x_m: np.ndarray
    beam: Beam
    rotary_inertia: bool
    samples: Samples
    phi: np.ndarray
    parts: ElementParts
    attachments: tuple[Attachment, ...] = ()
    profile: Profile | None = None
    material: Material | None = None
    core: Core | None = None
    meta: dict = field(default_factory=dict)

    @property
    def n_nodes(self) -> int:
        """Return the number of nodes."""
        return self.node_x_m.size

    @property
    def n_dof(self) -> int:
        """Return the number of DOFs (deflection and rotation per node)."""
        return 2 * self.node_x_m.size

    @property
    def n_elements(self) -> int:
        """Return the number of elements."""
        return self.node_x_m.size - 1

    @property
    def element_length_m(self) -> np.ndarray:
        """Return the element lengths, m."""
        return np.diff(self.node_x_m)

    @property
    def dofs(self) -> np.ndarray:
        """(e, 4) global DOF indices of each element."""
        return 2 * np.arange(self.n_elements)[:, None] + np.arange(4)[None, :]

    @property
    def translational_dofs(self) -> np.ndarray:
        """Return the translational DOFs (2 i for node i)."""
        return 2 * np.arange(self.n_nodes)

    def element_average(self, values: np.ndarray) -> np.ndarray:
        """Element mean of a sampled quantity: int v dx / L, (e,)."""
        s = self.samples
        return np.bincount(s.elem, s.weight_m * values, self.n_elements) / self.element_length_m

    def node_at(self, x_m: float) -> int:
        """Index of the node nearest to x_m."""
        return int(np.argmin(np.abs(self.node_x_m - x_m)))


def mesh_nodes(
    length_m: float, n_elements: int | None = None, element_length_m: float | None = None,
    stations_m=(),
) -> np.ndarray:
    """Node positions: a uniform grid (default ~1 in elements) with nodes at the stations.

    Grid nodes closer than 0.3 element to a station are dropped so no sliver element appears.
    """
    if n_elements is None:
        h = element_length_m if element_length_m else IN_TO_M
        n_elements = max(1, int(round(length_m / h)))
    if n_elements < 1:
        raise ValueError("the mesh needs at least one element")
    grid = np.linspace(0.0, length_m, n_elements + 1)
    st = np.asarray(stations_m, dtype=float).ravel()
    if np.any((st < -1e-12) | (st > length_m + 1e-12)):
        raise ValueError("a requested node lies outside the bat")
    if st.size == 0:
        return grid
    h = length_m / n_elements
    near = np.min(np.abs(grid[:, None] - st[None, :]), axis=1) < 0.3 * h
    near[[0, -1]] = False
    nodes = np.unique(np.concatenate([grid[~near], np.clip(st, 0.0, length_m)]))
    return nodes[np.concatenate([[True], np.diff(nodes) > 1e-9 * length_m])]


@functools.cache
def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre points and weights on [-1, 1], n of them (read-only arrays).

    ``numpy.polynomial.legendre.leggauss``, computed once per n: a change fit samples
    thousands of cored models.
    """
    g, w = np.polynomial.legendre.leggauss(n)
    g.flags.writeable = w.flags.writeable = False
    return g, w


def sample_sections(
    node_x_m: np.ndarray, profile: Profile, material: Material, core: Core | None,
    n_gauss: int = GAUSS_POINTS,
) -> Samples:
    """Gauss samples on every (element x profile piece x core zone) interval."""
    pieces = profile.segments()
    cuts = [pieces[:, 0], pieces[:, 1], node_x_m]
    if core is not None:
        x0, x1 = core.interval_m(profile.length_m)
        cuts.append(np.array([x0, x1 - core.empty_m, x1]))
    breaks = np.unique(np.concatenate(cuts))
    breaks = breaks[(breaks >= node_x_m[0]) & (breaks <= node_x_m[-1])]
    a, b = breaks[:-1], breaks[1:]
    keep = b - a > 1e-12 * profile.length_m
    a, b = a[keep], b[keep]
    g, gw = gauss_legendre(n_gauss)
    x = (0.5 * (a + b))[:, None] + (0.5 * (b - a))[:, None] * g[None, :]
    w = (0.5 * (b - a))[:, None] * gw[None, :]
    x, w = x.ravel(), w.ravel()
    elem = np.clip(np.searchsorted(node_x_m, x, side="right") - 1, 0, node_x_m.size - 2)
    xi = (x - node_x_m[elem]) / np.diff(node_x_m)[elem]
    D = profile.diameter_at(x)
    d_core = np.zeros_like(x)
    ratio_rho, ratio_e = np.zeros_like(x), np.zeros_like(x)
    if core is not None:
        x0, x1 = core.interval_m(profile.length_m)
        d_core[(x > x0) & (x < x1)] = core.diameter_m
        filled = (x > x0) & (x < x1 - core.empty_m)
        ratio_rho[filled], ratio_e[filled] = core.fill_density_ratio, core.fill_modulus_ratio
    props = section_props(D, material, d_core, ratio_rho, ratio_e)
    return Samples(elem, xi, w, x, props)


def parts_from_samples(
    node_x_m: np.ndarray, samples: Samples, beam: Beam, rotary_inertia: bool,
) -> tuple[np.ndarray, ElementParts]:
    """Shear parameter per element and the integrated element parts."""
    if beam not in ("euler", "timoshenko"):
        raise ValueError(f"unknown beam theory {beam!r} (euler or timoshenko)")
    L = np.diff(node_x_m)
    p = samples.props
    n_el = L.size
    if beam == "timoshenko":
        ei_avg = np.bincount(samples.elem, samples.weight_m * p.ei, n_el) / L
        kga_avg = np.bincount(samples.elem, samples.weight_m * p.kga, n_el) / L
        phi = 12 * ei_avg / (kga_avg * L**2)
    else:
        phi = np.zeros(n_el)
    rhoi = p.rhoi if rotary_inertia else np.zeros_like(p.rhoi)
    parts = element_parts(samples.elem, samples.xi, samples.weight_m, p.ei, p.kga, p.rhoa, rhoi,
                          L, phi)
    return phi, parts


def build_model(
    profile: Profile, material: Material, *, beam: Beam = "euler",
    rotary_inertia: bool | None = None, n_elements: int | None = None,
    element_length_m: float | None = None, stations_m=(), core: Core | None = None,
    attachments: tuple[Attachment, ...] = (),
) -> BatModel:
    """Mesh and integrate a bat. Rotary inertia defaults to on for Timoshenko, off for Euler."""
    if rotary_inertia is None:
        rotary_inertia = beam == "timoshenko"
    if core is not None:
        check_core(core, profile.length_m)
    nodes = mesh_nodes(profile.length_m, n_elements, element_length_m, stations_m)
    samples = sample_sections(nodes, profile, material, core)
    phi, parts = parts_from_samples(nodes, samples, beam, rotary_inertia)
    return BatModel(nodes, beam, rotary_inertia, samples, phi, parts, tuple(attachments),
                    profile, material, core)


def check_core(core: Core, length_m: float) -> None:
    """Raise ValueError unless the core fits the bat.

    0 < plug < depth <= the bat's length, and 0 <= empty length < depth - plug.
    """
    if not 0 < core.plug_m < core.depth_m <= length_m:
        raise ValueError("core: need 0 < plug < depth <= bat length")
    if not 0 <= core.empty_m < core.depth_m - core.plug_m:
        raise ValueError("core: need 0 <= empty length < depth - plug")


def with_core(model: BatModel, core: Core) -> BatModel:
    """Return the uncored ``model`` with ``core``, rebuilding only the elements it reaches.

    The same model as ``build_model(..., core=core)`` on the same mesh, bit for bit: the mesh
    does not depend on the core, an element the core interval does not reach keeps its
    samples, phi and parts, and those it reaches are sampled and integrated as
    ``sample_sections`` and ``parts_from_samples`` do over the whole bat (the same breaks
    in them, in the same order). A change fit steps a core's four parameters for every
    Jacobian, and each step's model differs from the uncored one over the core alone.
    """
    return with_cores(model, (core,))[0]


def with_cores(model: BatModel, cores) -> list[BatModel]:
    """Return ``with_core(model, c)`` for each core, all sampled and integrated in one pass.

    Each core's samples, phi and parts are the ones it gets alone (its own breaks, its
    elements' sums over their own samples, in order), so each model is the full build's
    bit for bit; the cores of a Jacobian's steps cost one pass instead of one each.
    """
    if model.core is not None:
        raise ValueError("with_core: the model must be uncored")
    cores = tuple(cores)
    profile, nodes = model.profile, model.node_x_m
    length = profile.length_m
    n_el = nodes.size - 1
    pieces = profile.segments()
    spans, a, b, cid = [], [], [], []
    for i, core in enumerate(cores):
        check_core(core, length)
        x0, x1 = core.interval_m(length)
        hit = np.flatnonzero((nodes[1:] > x0) & (nodes[:-1] < x1))
        first, last = int(hit[0]), int(hit[-1])
        span = nodes[first:last + 2]
        breaks = np.unique(np.concatenate([pieces[:, 0], pieces[:, 1], span,
                                           np.array([x0, x1 - core.empty_m, x1])]))
        breaks = breaks[(breaks >= span[0]) & (breaks <= span[-1])]
        lo, hi = breaks[:-1], breaks[1:]
        keep = hi - lo > 1e-12 * length
        spans.append((first, last))
        a.append(lo[keep])
        b.append(hi[keep])
        cid.append(np.full(int(keep.sum()), i))
    a, b, cid = np.concatenate(a), np.concatenate(b), np.concatenate(cid)
    g, gw = gauss_legendre(GAUSS_POINTS)
    x = ((0.5 * (a + b))[:, None] + (0.5 * (b - a))[:, None] * g[None, :]).ravel()
    w = ((0.5 * (b - a))[:, None] * gw[None, :]).ravel()
    cid = np.repeat(cid, GAUSS_POINTS)
    elem = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, n_el - 1)
    L = np.diff(nodes)
    xi = (x - nodes[elem]) / L[elem]
    D = profile.diameter_at(x)

    def per_core(name: str) -> np.ndarray:
        return np.array([float(getattr(c, name)) for c in cores])[cid]

    x0 = per_core("depth_m")
    x0 = length - x0
    x1 = length - per_core("plug_m")
    d_core = np.where((x > x0) & (x < x1), per_core("diameter_m"), 0.0)
    filled = (x > x0) & (x < x1 - per_core("empty_m"))
    ratio_rho = np.where(filled, per_core("fill_density_ratio"), 0.0)
    ratio_e = np.where(filled, per_core("fill_modulus_ratio"), 0.0)
    props = section_props(D, model.material, d_core, ratio_rho, ratio_e)
    bins = cid * n_el + elem
    Lk = np.tile(L, len(cores))
    phi_k = np.zeros(Lk.size)
    if model.beam == "timoshenko":
        ei_avg = np.bincount(bins, w * props.ei, Lk.size) / Lk
        kga_avg = np.bincount(bins, w * props.kga, Lk.size) / Lk
        used = np.unique(bins)
        phi_k[used] = 12 * ei_avg[used] / (kga_avg[used] * Lk[used] ** 2)
    rhoi = props.rhoi if model.rotary_inertia else np.zeros_like(props.rhoi)
    parts_k = element_parts(bins, xi, w, props.ei, props.kga, props.rhoa, rhoi, Lk, phi_k)
    bounds = np.searchsorted(cid, np.arange(len(cores) + 1))
    s = model.samples
    out = []
    for i, (core, (first, last)) in enumerate(zip(cores, spans, strict=True)):
        i0, i1 = np.searchsorted(s.elem, [first, last + 1])
        own = slice(bounds[i], bounds[i + 1])

        def merged(old: np.ndarray, new: np.ndarray, i0=i0, i1=i1, own=own) -> np.ndarray:
            return np.concatenate([old[:i0], new[own], old[i1:]])

        samples = Samples(merged(s.elem, elem), merged(s.xi, xi), merged(s.weight_m, w),
                          merged(s.x_m, x),
                          SectionProps(*(merged(getattr(s.props, k), getattr(props, k))
                                         for k in ("ei", "kga", "rhoa", "rhoi"))))
        rows = slice(i * n_el + first, i * n_el + last + 1)
        phi = model.phi.copy()
        phi[first:last + 1] = phi_k[rows]
        mats = []
        for k in ("k_bend", "k_shear", "m_trans", "m_rot"):
            m = getattr(model.parts, k).copy()
            m[first:last + 1] = getattr(parts_k, k)[rows]
            mats.append(m)
        out.append(replace(model, samples=samples, phi=phi, parts=ElementParts(*mats),
                           core=core))
    return out


def scale_sections(
    model: BatModel, ei=1.0, kga=1.0, rhoa=1.0, rhoi=1.0,
) -> BatModel:
    """Rebuild the model exactly with per-element (e,) or uniform factors on EI, kGA, rhoA, rhoI.

    Unlike adding beta_i k_i (first order), this recomputes phi, so it is the exact model of
    changed section properties; the nonlinear refinement and the virtual rig use it.
    """
    s = model.samples
    f = [np.broadcast_to(np.asarray(v, dtype=float), (model.n_elements,))[s.elem]
         for v in (ei, kga, rhoa, rhoi)]
    props = SectionProps(s.props.ei * f[0], s.props.kga * f[1], s.props.rhoa * f[2],
                         s.props.rhoi * f[3])
    samples = replace(s, props=props)
    phi, parts = parts_from_samples(model.node_x_m, samples, model.beam, model.rotary_inertia)
    return replace(model, samples=samples, phi=phi, parts=parts)


def element_at(model: BatModel, x_m: float) -> int:
    """Return the index of the element holding x_m (the first or last one beyond the ends)."""
    return int(np.clip(np.searchsorted(model.node_x_m, x_m, side="right") - 1, 0,
                       model.n_elements - 1))


def point_vector(model: BatModel, x_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(dofs, N_w) of the element containing x: a point load's consistent distribution."""
    if not model.node_x_m[0] - 1e-9 <= x_m <= model.node_x_m[-1] + 1e-9:
        raise ValueError(f"attachment at x = {x_m:.4f} m lies outside the bat")
    e = element_at(model, x_m)
    L = model.element_length_m[e]
    n_w = displacement_shape(np.array([(x_m - model.node_x_m[e]) / L]), np.array([L]),
                             np.array([model.phi[e]]))
    return model.dofs[e], n_w[0]


def attachment_matrices(model: BatModel) -> tuple[np.ndarray, np.ndarray]:
    """(K_a, M_a), n x n: springs to ground and point masses, distributed by N_w."""
    Ka = np.zeros((model.n_dof, model.n_dof))
    Ma = np.zeros_like(Ka)
    for a in model.attachments:
        dofs, n = point_vector(model, a.x_m)
        Ka[element_block(dofs)] += a.k_n_per_m * np.outer(n, n)
        Ma[element_block(dofs)] += a.mass_kg * np.outer(n, n)
    return Ka, Ma


def displacement_at(model: BatModel, shapes: np.ndarray, x_m) -> np.ndarray:
    """Transverse displacement of DOF vectors ``shapes`` (n, m) at positions x_m, (len(x), m)."""
    rows = []
    for x in np.atleast_1d(np.asarray(x_m, dtype=float)):
        dofs, n = point_vector(model, float(x))
        rows.append(n @ shapes[dofs])
    return np.array(rows)


def element_block(dofs: np.ndarray) -> tuple[slice, slice]:
    """Return the (rows, columns) slices of one element's 4 x 4 block of a global matrix.

    An element's DOFs are consecutive (2e..2e+3, ``BatModel.dofs``), so its block is a
    view: the same entries ``np.ix_(dofs, dofs)`` picks, without an index array.
    """
    first = int(dofs[0])
    return slice(first, first + 4), slice(first, first + 4)


def add_element_blocks(out: np.ndarray, element_mats: np.ndarray) -> np.ndarray:
    """Add each element's 4 x 4 matrix into ``out`` at its DOFs, in place; return ``out``.

    Element e holds DOFs 2e..2e+3 (``BatModel.dofs``), so the even elements' blocks are
    disjoint, and so are the odd ones': each set is added by one strided view of ``out``
    (..., N, N) with (..., e, 4, 4) mats, no per-element indexing. An entry gets at most two
    elements' terms and floating-point addition is commutative, so into zeros the sum is
    ``np.add.at``'s over the same terms bit for bit (``tests/test_fe_model.py``).
    """
    n_el = element_mats.shape[-3]
    if out.shape[-1] != 2 * (n_el + 1) or out.shape[-2] != out.shape[-1]:
        raise ValueError(f"{n_el} elements need a ({2 * n_el + 2}, {2 * n_el + 2}) matrix, "
                         f"got {out.shape[-2:]}")
    s = out.strides
    blocks = np.lib.stride_tricks.as_strided(
        out, shape=(*out.shape[:-2], n_el, 4, 4),
        strides=(*s[:-2], 2 * (s[-2] + s[-1]), s[-2], s[-1]), writeable=True)
    blocks[..., 0::2, :, :] += element_mats[..., 0::2, :, :]
    blocks[..., 1::2, :, :] += element_mats[..., 1::2, :, :]
    return out


def place(model: BatModel, element_mats: np.ndarray, factors=None) -> np.ndarray:
    """Assemble sum_i f_i c_i^T m_i c_i, n x n dense; factors (e,) or None for all ones."""
    mats = element_mats if factors is None else element_mats * np.asarray(factors)[:, None, None]
    return add_element_blocks(np.zeros((model.n_dof, model.n_dof)), mats)


def assemble(
    model: BatModel, beta_bend=None, beta_shear=None, alpha_trans=None, alpha_rot=None,
    with_attachments: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """K and M with element changes: K = sum (1+beta_b) k_b + (1+beta_s) k_s (+ springs), M alike.

    Changes are (e,) arrays or None (no change); docs/method.md: K_I = K_S + sum beta_i k_i.
    """
    def one_plus(v):
        return None if v is None else 1.0 + np.asarray(v, dtype=float)

    p = model.parts
    K = place(model, p.k_bend, one_plus(beta_bend)) + place(model, p.k_shear, one_plus(beta_shear))
    M = place(model, p.m_trans, one_plus(alpha_trans)) + place(model, p.m_rot, one_plus(alpha_rot))
    if with_attachments and model.attachments:
        Ka, Ma = attachment_matrices(model)
        K, M = K + Ka, M + Ma
    return K, M


def skyline_mask(model: BatModel) -> np.ndarray:
    """Boolean n x n sparsity pattern of the assembly (entries any element touches)."""
    mask = np.zeros((model.n_dof, model.n_dof), dtype=bool)
    d = model.dofs
    mask[d[:, :, None], d[:, None, :]] = True
    return mask
