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


@dataclass(frozen=True)
class MassEstimate:
    """An estimate of a mass and its standard uncertainty, kg."""

    mass_kg: float
    std_kg: float


def sensor_mass_from_mass_line(
    mass_line: np.ndarray, x_m: np.ndarray, x_drive_m: float, sigma: float,
    bare_drive: float,
) -> MassEstimate:
    """Estimate the accelerometer's mass from the driving point's mass line.

    The mass line is a straight line in x (module docstring); its value at the driving point,
    a_d, is the rigid-body flexibility of the bat with its accelerometer there. A point mass
    m_s at the driving point adds m_s [1, x_d][1, x_d]^T to the rigid-body mass matrix R, so
    (Sherman-Morrison) a_d = a_0 / (1 + m_s a_0) with a_0 that of the bare bat, and

        m_s = 1 / a_d - 1 / a_0,    std(m_s) = std(a_d) / a_d^2,

    std(a_d) that of the fitted line at x_d with ``sigma`` per point.

    Parameters
    ----------
    mass_line : ndarray
        (n,) the driving point's row of the measured mass line, 1/kg.
    x_m : ndarray
        (n,) node positions, m.
    x_drive_m : float
        The driving point (the accelerometer), m.
    sigma : float
        Standard uncertainty of one entry of the row, 1/kg.
    bare_drive : float
        a_0: the bare bat's mass line at the driving point (from its mass properties), 1/kg.

    Returns
    -------
    MassEstimate
        The accelerometer's mass, kg.
    """
    x = np.asarray(x_m, dtype=float)
    design = np.column_stack([np.ones(x.size), x - x_drive_m])
    coef, *_ = np.linalg.lstsq(design, np.asarray(mass_line, dtype=float), rcond=None)
    a_d = float(coef[0])
    std_a = sigma * float(np.sqrt(np.linalg.inv(design.T @ design)[0, 0]))
    return MassEstimate(1.0 / a_d - 1.0 / bare_drive, std_a / a_d**2)


def sensor_mass_from_shifts(
    rel_shift: np.ndarray, per_kg: np.ndarray, sigma_rel: float,
) -> MassEstimate:
    """Estimate the accelerometer's mass from every mode's frequency shift at its node.

    A point mass m_s at x_s shifts mode r by d f_r / f_r = -1/2 m_s phi_r(x_s)^2 (phi_r
    mass-normalised, Rayleigh), a pattern over the modes that a modulus error, the same
    fraction for every mode, does not have. Weighted least squares of

        ln(f_r / f_r^0) = c + s_r m_s,    s_r = -1/2 phi_r(x_s)^2,

    over the modes, c free (the modulus), with ``sigma_rel`` per mode; the uncertainty is the
    fit's (at least ``sigma_rel``'s, more when the modes scatter about the line more).

    Parameters
    ----------
    rel_shift : ndarray
        (r,) ln(f_r / f_r^0): measured frequencies against the model's without the
        accelerometer.
    per_kg : ndarray
        (r,) s_r = d ln f_r / d m_s, 1/kg.
    sigma_rel : float
        Standard uncertainty of one relative shift.

    Returns
    -------
    MassEstimate
        The accelerometer's mass, kg (uncertainty infinite with fewer than three modes or
        a shift pattern no different from a modulus's).
    """
    b, s = np.asarray(rel_shift, dtype=float), np.asarray(per_kg, dtype=float)
    spread = s - s.mean()
    ss = float(spread @ spread)
    if b.size < 3 or ss <= 0:
        return MassEstimate(0.0, float("inf"))
    m = float(spread @ (b - b.mean()) / ss)
    resid = b - b.mean() - m * spread
    scale2 = max(sigma_rel**2, float(resid @ resid) / (b.size - 2))
    return MassEstimate(m, float(np.sqrt(scale2 / ss)))


def combine_masses(estimates: list[MassEstimate]) -> MassEstimate:
    """Combine independent estimates weighted by their inverse variances.

    m = sum(m_i / s_i^2) / sum(1 / s_i^2), std = sum(1 / s_i^2)^(-1/2).
    """
    w = np.array([1.0 / e.std_kg**2 if e.std_kg > 0 else np.inf for e in estimates])
    m = np.array([e.mass_kg for e in estimates])
    if np.any(np.isinf(w)):
        exact = np.isinf(w)
        return MassEstimate(float(np.mean(m[exact])), 0.0)
    return MassEstimate(float(w @ m / w.sum()), float(1.0 / np.sqrt(w.sum())))
