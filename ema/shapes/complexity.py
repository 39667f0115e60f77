"""Complex modes: complexity indicators and the nearest real (normal) mode.

For a complex shape psi (n,), write x = Re psi, y = Im psi and the 2x2 matrix
C = [[x.x, x.y], [x.y, y.y]] with eigenvalues l1 >= l2 and principal direction u.

- MPC, modal phase collinearity (Pappa, Elliott, Schenk 1993): ((l1 - l2) / (l1 + l2))^2;
  1 for a mode whose components all lie on one line in the complex plane (a real mode times a
  complex constant), 0 for a circularly spread one.
- MPD, mean phase deviation (degrees): the |psi_j|-weighted mean angle between each component
  and the principal line.
- Real mode: psi rotated so that its real part has the largest norm (Niedbal; Gladwell and
  Ahmadian's "nearest real vector"), real part taken: phi = Re(psi exp(-i theta)), theta the
  angle of u. It preserves the modal scaling of an (almost) real psi.
"""

from __future__ import annotations

import numpy as np


def _principal(psi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (r, 2) ascending and principal unit directions (r, 2) of the columns."""
    x, y = psi.real, psi.imag
    c = np.empty((psi.shape[1], 2, 2))
    c[:, 0, 0] = np.sum(x * x, axis=0)
    c[:, 1, 1] = np.sum(y * y, axis=0)
    c[:, 0, 1] = c[:, 1, 0] = np.sum(x * y, axis=0)
    val, vec = np.linalg.eigh(c)
    return val, vec[:, :, 1]


def mpc(psi: np.ndarray) -> np.ndarray:
    """Return the modal phase collinearity of each column of psi.

    Parameters
    ----------
    psi : ndarray
        (n, r) complex shapes.

    Returns
    -------
    ndarray
        (r,) MPC, 0..1 (1: the entries lie on one line in the complex plane, a real mode).
    """
    psi = np.asarray(psi, dtype=complex).reshape(np.shape(psi)[0], -1)
    val, _ = _principal(psi)
    tot = val[:, 1] + val[:, 0]
    return ((val[:, 1] - val[:, 0]) / np.where(tot > 0, tot, np.inf)) ** 2


def mpd(psi: np.ndarray) -> np.ndarray:
    """Return the mean phase deviation of each column of psi from its principal line.

    Parameters
    ----------
    psi : ndarray
        (n, r) complex shapes.

    Returns
    -------
    ndarray
        (r,) MPD, degrees (0: a real mode).
    """
    psi = np.asarray(psi, dtype=complex).reshape(np.shape(psi)[0], -1)
    _, u = _principal(psi)
    amp = np.abs(psi)
    proj = np.abs(psi.real * u[None, :, 0] + psi.imag * u[None, :, 1])
    ang = np.degrees(np.arccos(np.clip(proj / np.where(amp > 0, amp, np.inf), 0.0, 1.0)))
    ang = np.where(amp > 0, ang, 0.0)
    return np.sum(amp * ang, axis=0) / np.maximum(np.sum(amp, axis=0), np.finfo(float).tiny)


def real_modes(psi: np.ndarray) -> np.ndarray:
    """Return the nearest real vectors of the columns of psi: Re(psi exp(-i theta)).

    The sign is arbitrary here; callers fix it (``ema.shapes.scaling.fix_sign``).

    Parameters
    ----------
    psi : ndarray
        (n, r) complex shapes.

    Returns
    -------
    ndarray
        (n, r) real shapes, same scale.
    """
    psi = np.asarray(psi, dtype=complex).reshape(np.shape(psi)[0], -1)
    _, u = _principal(psi)
    rot = np.exp(-1j * np.arctan2(u[:, 1], u[:, 0]))
    return (psi * rot[None, :]).real
