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

Estimating L0 (``low_band_mass_line``): over a wide band the constant term trades off against
what the residual terms represent badly (a mode just above the band, a close pair fitted
with one pole), a bias of several % of the mass line. It is therefore re-estimated by LSFD
on the band below the second bending mode only, from ``max(lo, 4 f_s)`` to 0.85 f_2, with
the poles of the modes below 1.1 f_2, lines within 5 % of a pole left out (a pair of close
modes fitted as one pole leaves its misfit there), and f_s = sqrt(-L1 / L0) / 2 pi the
suspension frequency that the first estimate's residual terms imply (the Taylor terms
L0 + L1 / w^2 of the suspension modes hold for w >> w_s only). On the virtual bat (bungees
50-800 N/m, 0.5 % noise, one or two bending planes) the driving-point value is within 0.1 %.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema.shapes.lsfd import lsfd


@dataclass(frozen=True)
class RigidBody:
    """Rigid-body properties implied by the modal scaling (None where not identifiable)."""

    mass_kg: float | None
    x_cg_m: float | None
    pitch_inertia_kg_m2: float | None
    mass_upper_bound_kg: float | None = None


def rigid_body_from_modes(shapes: np.ndarray, x_m: np.ndarray) -> RigidBody:
    """Return mass, centre of mass and pitch inertia from the rigid-body shapes.

    Parameters
    ----------
    shapes : ndarray
        (n, s) >= 2 mass-normalised rigid-body (suspension) shapes, 1/sqrt(kg).
    x_m : ndarray
        (n,) node positions, m.

    Returns
    -------
    RigidBody
        Mass (kg), centre of mass (m) and pitch inertia (kg m^2).
    """
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
    """Return what one driving-point row of the mass line says of the rigid body.

    Parameters
    ----------
    mass_line : ndarray
        (n,) lower residual L0 of the FRFs sharing the driving point, 1/kg.
    x_m : ndarray
        (n,) node positions, m.
    x_drive_m : float
        Driving point position, m.
    known_mass_kg : float, optional
        The mass, kg, when known (then the centre of mass and inertia follow).

    Returns
    -------
    RigidBody
        What the row determines (see the module docstring); None where it cannot.
    """
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


LOW_BAND_END = 0.85  # of the second bending mode's frequency
POLES_UP_TO = 1.1  # poles of the modes below this multiple of it join the LSFD
POLE_GAP = 0.05  # lines within this relative distance of a pole are left out
SUSPENSION_MARGIN = 4.0  # the band starts this many suspension frequencies up


@dataclass(frozen=True)
class MassLineEstimate:
    """The lower residual L0 of every FRF (1/kg) from the low band, and that band (Hz)."""

    mass_line: np.ndarray
    band_hz: tuple[float, float]


def low_band_mass_line(
    freq_hz: np.ndarray, frf: np.ndarray, poles: np.ndarray, quantity: str, lo_hz: float,
    driving_column: int,
) -> MassLineEstimate | None:
    """Estimate the mass line of every FRF column from the band below the second bending mode.

    See the module docstring.

    Parameters
    ----------
    freq_hz : ndarray
        (F,) lines, Hz.
    frf : ndarray
        (F, n_frf) FRFs of ``quantity``.
    poles : ndarray
        (m,) the elastic modes' continuous poles, rad/s.
    quantity : str
        "receptance", "mobility" or "accelerance".
    lo_hz : float
        The fitted band's start (above the suspension modes), Hz.
    driving_column : int
        The driving-point FRF's column (its L1 / L0 gives the suspension frequency).

    Returns
    -------
    MassLineEstimate or None
        None when the test has fewer than two elastic modes or too few lines.
    """
    poles = np.asarray(poles, dtype=complex)
    f_r = np.abs(poles) / (2 * np.pi)
    order = np.sort(f_r)
    if order.size < 2:
        return None
    second = order[order > 1.5 * order[0]]
    if second.size == 0:
        return None
    hi = LOW_BAND_END * second[0]
    used = poles[f_r < POLES_UP_TO * second[0]]
    f = np.asarray(freq_hz, dtype=float)
    keep = np.all(np.abs(f[:, None] / (np.abs(used)[None, :] / (2 * np.pi)) - 1) > POLE_GAP,
                  axis=1)
    f, h = f[keep], np.asarray(frf).reshape(np.size(freq_hz), -1)[keep]
    def lower(lo: float) -> np.ndarray | None:
        if np.sum((f >= lo) & (f <= hi)) < 4 * used.size + 16:
            return None
        return lsfd(f, h, used, quantity, (lo, hi)).lower

    lo = float(lo_hz)
    low = lower(lo)
    if low is None:
        return None
    l0, l1 = low[driving_column]
    f_s = np.sqrt(max(-l1 / l0, 0.0)) / (2 * np.pi) if l0 > 0 else 0.0
    start = SUSPENSION_MARGIN * f_s
    if lo < start < hi / 2:  # start well above the implied suspension frequency
        second_pass = lower(start)
        if second_pass is not None:
            lo, low = start, second_pass
    return MassLineEstimate(low[:, 0].copy(), (lo, hi))
