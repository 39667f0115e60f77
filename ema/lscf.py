"""Polyreference least-squares complex-frequency (LSCF / PolyMAX) poles over an order sweep.

Right matrix-fraction model in the z-domain (Peeters, Van der Auweraer, Guillaume, Leuridan,
"The PolyMAX frequency-domain method", Shock and Vibration 11, 2004):

    H_o(w) = B_o(z) A(z)^-1,   z = exp(i w dt),   B_o(z) = sum_k z^k b_ok (1 x m),
    A(z) = sum_k z^k A_k (m x m),   k = 0..p,   dt = 1 / (2 f_hi)

for outputs o = 1..l and m references. Linearised error per output and line,
E_o = sum_k z^k (b_ok - H_o A_k), gives for each output the blocks
R = Re(G^H G), S_o = Re(G^H F_o), T_o = Re(F_o^H F_o) with G_fk = z_f^k and
F_o,f(k,b) = -z_f^k H_ob(f). Eliminating the numerators (b_o = -R^-1 S_o alpha) leaves the
reduced normal equations

    M alpha = 0,   M = sum_o (T_o - S_o^T R^-1 S_o),

solved with the constraint A_p = I. The poles are the eigenvalues z_r of the block companion
matrix of A(z), lambda_r = ln(z_r) / dt; its eigenvectors give the participation factors
L_r (A(z_r) L_r = 0) and B_o(z_r) L_r is proportional to the mode shape at output o.

All blocks are Toeplitz in (j, k): they are built once from the moments
c_n[X] = sum_f z_f^n X_f, n = -p..p, and every order of the sweep takes leading sub-blocks.

Roving-hammer tests (one accelerometer, many impacts) are fitted transposed: by reciprocity
H_jk = H_kj, so the impacts become outputs and the single accelerometer the only reference.
The caller passes the FRFs in that orientation (see ``ema.fit``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PoleSweep:
    """Poles of every model order of an LSCF sweep, flattened over orders.

    Attributes:
        order: (N,) model order p that produced each pole.
        pole: (N,) continuous-time pole lambda = -zeta w_n + i w_d, rad/s (upper half-plane only).
        freq_hz: (N,) undamped natural frequency |lambda| / 2 pi, Hz.
        damping_ratio: (N,) -Re(lambda) / |lambda|.
        shape: (N, l) complex shape estimate B(z_r) L_r at the l outputs (unscaled).
        participation: (N, m) participation factors L_r (unit norm).
        orders: (n_orders,) the orders of the sweep, ascending.
        band_hz: (lo, hi) band used.
    """

    order: np.ndarray
    pole: np.ndarray
    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    shape: np.ndarray
    participation: np.ndarray
    orders: np.ndarray
    band_hz: tuple[float, float]


def _moments(zf: np.ndarray, x: np.ndarray, p: int) -> np.ndarray:
    """c_n[x] = sum_f z_f^n x_f for n = -p..p; x is (F, ...) -> (2p+1, ...)."""
    n = np.arange(-p, p + 1)
    zn = zf[None, :] ** n[:, None]  # (2p+1, F)
    return np.tensordot(zn, x, axes=(1, 0))


def _toeplitz_index(p: int) -> np.ndarray:
    """Index into the moment axis (n = -p..p stored at n + p) for block entry (j, k): k - j."""
    j = np.arange(p + 1)
    return (j[None, :] - j[:, None]) + p


def lscf_sweep(
    freq_hz: np.ndarray,
    frf: np.ndarray,
    band_hz: tuple[float, float],
    max_order: int,
    min_order: int = 2,
) -> PoleSweep:
    """Poles of polyreference LSCF models of orders min_order..max_order.

    Args:
        freq_hz: (F,) evenly spaced frequency lines, Hz.
        frf: (F, l, m) FRFs, l outputs by m references (any quantity; the poles do not care).
        band_hz: (lo, hi) frequency band fitted, Hz.
        max_order: highest polynomial order p (p*m poles at order p).
        min_order: lowest order.

    Returns:
        A PoleSweep with the poles in the band with positive damped frequency.
    """
    freq_hz = np.asarray(freq_hz, dtype=float)
    h = np.asarray(frf, dtype=complex)
    if h.ndim != 3 or h.shape[0] != freq_hz.size:
        raise ValueError(f"FRF array of shape {h.shape} does not match {freq_hz.size} lines")
    lo, hi = float(band_hz[0]), float(band_hz[1])
    sel = (freq_hz >= lo) & (freq_hz <= hi)
    p_max = int(max_order)
    if sel.sum() < 4 * p_max:
        raise ValueError(f"band {lo:g}-{hi:g} Hz has too few lines for order {p_max}")
    f = freq_hz[sel]
    h = h[sel]
    _, n_out, m = h.shape
    # Equalise the outputs: each output row contributes with unit RMS.
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=(0, 2)))
    h = h / np.where(rms > 0, rms, 1.0)[None, :, None]

    dt = 1.0 / (2.0 * hi)
    zf = np.exp(2j * np.pi * f * dt)
    ones = np.ones(f.size, dtype=complex)
    c_r = _moments(zf, ones, p_max).real  # (2p+1,)
    c_s = -_moments(zf, h, p_max).real  # (2p+1, l, m)
    hh = np.conj(h)[:, :, :, None] * h[:, :, None, :]  # (F, l, m, m)
    c_t = _moments(zf, hh, p_max).real  # (2p+1, l, m, m)

    idx = _toeplitz_index(p_max)  # (p+1, p+1)
    r_full = c_r[idx]  # (P, P)
    s_full = np.moveaxis(c_s[idx], 2, 0)  # (l, P, P, m): S_o[j, k, b]
    s_full = s_full.reshape(n_out, p_max + 1, (p_max + 1) * m)
    t_full = np.moveaxis(c_t[idx], 2, 0)  # (l, P, P, m, m): T_o[j, k, a, b]
    t_full = np.transpose(t_full, (0, 1, 3, 2, 4)).reshape(
        n_out, (p_max + 1) * m, (p_max + 1) * m
    )  # rows (j, a), columns (k, b)

    orders, pole_l, shape_l, part_l, order_l = [], [], [], [], []
    for p in range(int(min_order), p_max + 1):
        n_c = (p + 1) * m
        r = r_full[: p + 1, : p + 1]
        s = s_full[:, : p + 1, :n_c]
        t = t_full[:, :n_c, :n_c]
        rinv_s = np.linalg.solve(r, s)  # (l, P, n_c)
        mm = np.sum(t - np.transpose(s, (0, 2, 1)) @ rinv_s, axis=0)
        top = np.linalg.solve(mm[: p * m, : p * m], -mm[: p * m, p * m :])  # (p m, m)
        alpha = np.vstack([top, np.eye(m)])  # (n_c, m)
        comp = np.zeros((p * m, p * m))
        comp[: (p - 1) * m, m:] = np.eye((p - 1) * m)
        # last block row: [-A_0, -A_1, ..., -A_{p-1}], A_k = top[k m:(k+1) m, :]
        comp[(p - 1) * m :, :] = -top.reshape(p, m, m).transpose(1, 0, 2).reshape(m, p * m)
        zr, vec = np.linalg.eig(comp)
        lam = np.log(zr.astype(complex)) / dt
        keep = (lam.imag > 0) & np.isfinite(lam)
        lam, vec, zr = lam[keep], vec[:, keep], zr[keep]
        lr = vec[:m, :]
        lr = lr / np.linalg.norm(lr, axis=0, keepdims=True)
        beta = -(rinv_s @ alpha)  # (l, P, m): b_o,k
        zk = zr[None, :] ** np.arange(p + 1)[:, None]  # (P, n_poles)
        shape = np.einsum("okb,bn,kn->no", beta, lr, zk)
        orders.append(p)
        pole_l.append(lam)
        shape_l.append(shape)
        part_l.append(lr.T)
        order_l.append(np.full(lam.size, p))
    pole = np.concatenate(pole_l)
    wn = np.abs(pole)
    return PoleSweep(
        order=np.concatenate(order_l),
        pole=pole,
        freq_hz=wn / (2 * np.pi),
        damping_ratio=-pole.real / wn,
        shape=np.concatenate(shape_l, axis=0),
        participation=np.concatenate(part_l, axis=0),
        orders=np.asarray(orders),
        band_hz=(lo, hi),
    )
