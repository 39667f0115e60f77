"""Two-node planar beam element (DOFs w1, theta1, w2, theta2), Euler-Bernoulli or Timoshenko.

Interdependent interpolation (Friedman & Kosmatka 1993, Comput. Struct. 47:473) with
phi = 12 EI / (kGA L^2) and xi = x / L:

    N_w  = [2xi^3 - 3xi^2 - phi xi + 1 + phi,  L (xi^3 - (2 + phi/2) xi^2 + (1 + phi/2) xi),
            -2xi^3 + 3xi^2 + phi xi,          L (xi^3 - (1 - phi/2) xi^2 - (phi/2) xi)] / (1+phi)
    N_th  = [6 (xi^2 - xi) / L, 3xi^2 - (4 + phi) xi + 1 + phi,
             -6 (xi^2 - xi) / L, 3xi^2 - (2 - phi) xi] / (1+phi)

curvature kappa = d theta/dx, shear strain gamma = dw/dx - theta (constant over the element).
phi = 0 gives the Hermite cubic (Euler-Bernoulli) element. The matrices are kept in separate
physical parts, integrated over the element with the local section properties:

    k_bend = int EI kappa kappa^T,   k_shear = int kGA gamma gamma^T,
    m_trans = int rhoA N_w N_w^T,    m_rot = int rhoI N_th N_th^T.

For a uniform element k_bend + k_shear is the exact Timoshenko stiffness (Przemieniecki), and
because the shape functions solve the static problem exactly, k_bend = EI dK/dEI and
k_shear = kGA dK/dkGA: a factor on each part is a first-order change of EI or kGA.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ShapeFunctions:
    """Interpolation at P sample points (each (P, 4))."""

    n_w: np.ndarray
    n_theta: np.ndarray
    kappa: np.ndarray
    gamma: np.ndarray


def displacement_shape(xi: np.ndarray, length_m: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Return N_w, the displacement's shape functions at xi in [0, 1], (..., 4).

    ``shape_functions(...).n_w`` alone: a point's consistent vector needs no more.
    """
    x, L, p = (np.asarray(a, dtype=float) for a in np.broadcast_arrays(xi, length_m, phi))
    c = 1.0 / (1.0 + p)
    x2, x3 = x * x, x * x * x
    return np.stack([
        2 * x3 - 3 * x2 - p * x + 1 + p,
        L * (x3 - (2 + p / 2) * x2 + (1 + p / 2) * x),
        -2 * x3 + 3 * x2 + p * x,
        L * (x3 - (1 - p / 2) * x2 - (p / 2) * x),
    ], axis=-1) * c[..., None]


def shape_functions(xi: np.ndarray, length_m: np.ndarray, phi: np.ndarray) -> ShapeFunctions:
    """Shape functions of the element at local coordinates xi in [0, 1] (arrays of one shape)."""
    x, L, p = (np.asarray(a, dtype=float) for a in np.broadcast_arrays(xi, length_m, phi))
    c = 1.0 / (1.0 + p)
    x2 = x * x
    n_w = displacement_shape(x, L, p)
    n_theta = np.stack([
        6 * (x2 - x) / L, 3 * x2 - (4 + p) * x + 1 + p, -6 * (x2 - x) / L, 3 * x2 - (2 - p) * x,
    ], axis=-1) * c[..., None]
    kappa = np.stack([
        6 * (2 * x - 1) / L**2, (6 * x - 4 - p) / L, -6 * (2 * x - 1) / L**2, (6 * x - 2 + p) / L,
    ], axis=-1) * c[..., None]
    gamma = np.stack([-p / L, -p / 2, p / L, -p / 2], axis=-1) * c[..., None]
    return ShapeFunctions(n_w, n_theta, kappa, gamma)


@dataclass(frozen=True)
class ElementParts:
    """Element matrix parts, each (e, 4, 4), DOF order (w1, theta1, w2, theta2)."""

    k_bend: np.ndarray
    k_shear: np.ndarray
    m_trans: np.ndarray
    m_rot: np.ndarray


def _equal_runs(elem: np.ndarray) -> int | None:
    """Return g when ``elem`` is runs of g equal entries, no two runs of one element; else None.

    A segment's Gauss points (``updating.inspect.segments``): g samples an element, each
    element once.
    """
    if elem.size == 0:
        return None
    g = int(np.argmax(elem != elem[0])) or elem.size
    if elem.size % g:
        return None
    first = elem[::g]
    if np.any(elem.reshape(-1, g) != first[:, None]) or np.unique(first).size != first.size:
        return None
    return g


def element_parts(
    elem: np.ndarray, xi: np.ndarray, weight_m: np.ndarray, ei: np.ndarray, kga: np.ndarray,
    rhoa: np.ndarray, rhoi: np.ndarray, length_m: np.ndarray, phi: np.ndarray,
) -> ElementParts:
    """Integrate the parts from P quadrature samples.

    Parameters
    ----------
    elem : np.ndarray
        (P,) element index of each sample.
    xi : np.ndarray
        (P,) local coordinate of each sample.
    weight_m : np.ndarray
        (P,) quadrature weight, m.
    ei, kga, rhoa, rhoi : np.ndarray
        (P,) section properties at the samples.
    length_m, phi : np.ndarray
        (e,) element lengths and shear parameters (phi = 0: Euler-Bernoulli).
    """
    sf = shape_functions(xi, length_m[elem], phi[elem])
    n_el = length_m.size
    runs = _equal_runs(elem)

    def integrate(coef: np.ndarray, b: np.ndarray) -> np.ndarray:
        out = np.zeros((n_el, 4, 4))
        terms = (weight_m * coef)[:, None, None] * b[:, :, None] * b[:, None, :]
        if runs is None:
            np.add.at(out, elem, terms)
            return out
        # each element's samples in one run of g: the same sums as add.at's, in its order
        terms = terms.reshape(-1, runs, 4, 4)
        acc = np.zeros(terms.shape[:1] + (4, 4))
        for j in range(runs):
            acc += terms[:, j]
        out[elem[::runs]] = acc
        return out

    return ElementParts(
        k_bend=integrate(ei, sf.kappa),
        k_shear=integrate(kga, sf.gamma),
        m_trans=integrate(rhoa, sf.n_w),
        m_rot=integrate(rhoi, sf.n_theta),
    )
