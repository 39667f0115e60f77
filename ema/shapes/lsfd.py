"""Least-squares frequency-domain (LSFD) residues and residual terms for fixed poles.

Each FRF, in its own quantity (receptance q = 0, mobility q = 1, accelerance q = 2), is

    H(w) = (i w)^q [ sum_r ( A_r / (i w - lambda_r) + conj(A_r) / (i w - conj(lambda_r)) )
                     + L0 (i w)^-2 + L1 (i w)^-4 + U0 + U1 (i w)^2 ]

with complex residues A_r (receptance pole-residue form, m/N/s) and real residual terms:
L0, L1 for the modes below the band (rigid-body/suspension modes: each contributes
phi_j phi_k / (w_s^2 - w^2) = -phi_j phi_k / w^2 (1 + w_s^2 / w^2 + ...) to the receptance,
so L0 = sum_s phi_j phi_k, the *mass line* in 1/kg, and L1 = -sum_s w_s^2 phi_j phi_k) and
U0, U1 for the modes above it (phi phi / (w_s^2 - w^2) = phi phi / w_s^2 (1 + w^2 / w_s^2 + ...):
U0 = sum_s phi_j phi_k / w_s^2 in m/N, U1 = -sum_s phi_j phi_k / w_s^4). The model is linear in
the unknowns; all FRFs share the basis, so one real least-squares solve (thin QR) with many
right-hand sides gives all of them (Ewins, Modal Testing, 2nd ed., 4.4; Peeters et al. 2004).

For real normal modes, phi_j phi_k / (w_r^2 - w^2 + 2 i zeta_r w_r w) has the residues
A_r = phi_j phi_k / (2 i w_d) at lambda_r = -zeta_r w_r + i w_d; ``ema.shapes.scaling`` uses that.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_triangular

QUANTITY_POWER = {"receptance": 0, "mobility": 1, "accelerance": 2}


@dataclass(frozen=True)
class LsfdResult:
    """Residues and residual terms of every FRF column, and the synthesised FRFs.

    Attributes
    ----------
    residue
        (n_frf, m) complex A_r (receptance pole-residue form).
    lower
        (n_frf, 2) real (L0, L1): mass line 1/kg and its 1/w^4 correction.
    upper
        (n_frf, 2) real (U0, U1): residual flexibility m/N and its w^2 term.
    freq_hz
        (F_band,) the lines fitted.
    synth
        (F_band, n_frf) synthesised FRFs on those lines.
    """

    residue: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    freq_hz: np.ndarray
    synth: np.ndarray


def _basis(
    freq_hz: np.ndarray, poles: np.ndarray, q: int, lower: bool, upper: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Mode basis (F, m, 2) for (Re A, Im A) and residual basis (F, 4) (L0, L1, U0, U1)."""
    s = 2j * np.pi * freq_hz[:, None]
    sq = s**q
    a = 1.0 / (s - poles[None, :])
    b = 1.0 / (s - np.conj(poles)[None, :])
    modes = np.stack([sq * (a + b), sq * 1j * (a - b)], axis=-1)
    s1 = s[:, 0]
    res = np.stack([s1 ** (q - 2), s1 ** (q - 4), s1**q, s1 ** (q + 2)], axis=-1)
    res = res * np.array([lower, lower, upper, upper], dtype=float)[None, :]
    return modes, res


def lsfd(
    freq_hz: np.ndarray,
    frf: np.ndarray,
    poles: np.ndarray,
    quantity: str,
    band_hz: tuple[float, float],
    lower: bool = True,
    upper: bool = True,
    weight: np.ndarray | None = None,
) -> LsfdResult:
    """Residues of the poles in every FRF column of frf (F, n_frf) by linear least squares.

    Parameters
    ----------
    freq_hz
        (F,) lines, Hz (lines at 0 Hz are never used).
    frf
        (F, n_frf) complex FRFs of ``quantity``.
    poles
        (m,) continuous poles in the upper half-plane, rad/s.
    quantity
        "receptance", "mobility" or "accelerance".
    band_hz
        (lo, hi) lines used.
    lower, upper
        include the lower (L0, L1) and upper (U0, U1) residual terms.
    weight
        (F,) optional weight of each line (weighted least squares, e.g. the inverse variance
        of an H1 estimate, ``ema.poles.local_support.line_weight``); None: all alike.

    Returns
    -------
    LsfdResult
        Residues, residual terms and the synthesis on the band's lines.
    """
    if quantity not in QUANTITY_POWER:
        raise ValueError(f"unknown FRF quantity {quantity!r}")
    freq_hz = np.asarray(freq_hz, dtype=float)
    frf = np.asarray(frf, dtype=complex).reshape(freq_hz.size, -1)
    sel = (freq_hz >= band_hz[0]) & (freq_hz <= band_hz[1]) & (freq_hz > 0)
    f = freq_hz[sel]
    h = frf[sel]
    poles = np.atleast_1d(np.asarray(poles, dtype=complex))
    m = poles.size
    modes, res = _basis(f, poles, QUANTITY_POWER[quantity], lower, upper)
    basis = np.concatenate([modes.reshape(f.size, 2 * m), res], axis=1)  # (F, 2m + 4)
    a = np.concatenate([basis.real, basis.imag], axis=0)
    y = np.concatenate([h.real, h.imag], axis=0)
    if weight is not None:  # weighted least squares: rows scaled by sqrt(weight) per line
        root = np.sqrt(np.tile(np.asarray(weight, dtype=float)[sel], 2))[:, None]
        a, y = a * root, y * root
    scale = np.linalg.norm(a, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    used = np.linalg.norm(a, axis=0) > 0
    q, r = np.linalg.qr(a[:, used] / scale[used])  # thin QR: one factorisation, all FRFs
    coef = np.zeros((a.shape[1], y.shape[1]))
    coef[used] = solve_triangular(r, q.T @ y) / scale[used][:, None]  # (2m + 4, n_frf)
    residue = (coef[0 : 2 * m : 2] + 1j * coef[1 : 2 * m : 2]).T  # (n_frf, m)
    synth = basis @ coef
    return LsfdResult(
        residue=residue,
        lower=coef[2 * m : 2 * m + 2].T.copy(),
        upper=coef[2 * m + 2 : 2 * m + 4].T.copy(),
        freq_hz=f,
        synth=synth,
    )
