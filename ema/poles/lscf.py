"""Polyreference least-squares complex-frequency (LSCF / PolyMAX) poles over an order sweep.

Right matrix-fraction model in the z-domain (Peeters, Van der Auweraer, Guillaume, Leuridan,
"The PolyMAX frequency-domain method", Shock and Vibration 11, 2004), here in its
frequency-shifted complex-coefficient form so that any band [f_lo, f_hi] maps onto (almost)
the whole unit circle:

    H_o(w) = B_o(z) A(z)^-1,   z = exp(i (w - w_c) dt),   w_c = pi (f_lo + f_hi),
    dt ~ span / (f_hi - f_lo),   B_o(z) = sum_k z^k b_ok (1 x m),   A(z) = sum_k z^k A_k (m x m),

k = 0..p, for outputs o = 1..l and m references; the band covers |angle z| <= span pi
(span = 0.9), where the powers z^k are nearly orthogonal and the normal equations stay well
conditioned at any band position (the real-coefficient form over [0, f_hi] becomes singular
for a band far from 0 Hz). Each mode in the band is one pole (its conjugate lies outside the
band and is absorbed by the model). Linearised error per output and line,
E_o = sum_k z^k (b_ok - H_o A_k), gives the blocks R = G^H G, S_o = G^H F_o,
T_o = F_o^H F_o with G_fk = z_f^k and F_o,f(k,b) = -z_f^k H_ob(f). Eliminating the numerators
(b_o = -R^-1 S_o alpha) leaves the reduced normal equations

    M alpha = 0,   M = sum_o (T_o - S_o^H R^-1 S_o),

solved with the constraint A_p = I. The poles are the eigenvalues z_r of the block companion
matrix of A(z), lambda_r = ln(z_r) / dt + i w_c; its eigenvectors give the participation
factors L_r (A(z_r) L_r = 0) and B_o(z_r) L_r is proportional to the mode shape at output o.

All blocks are Toeplitz in (j, k): they are built once from the moments
c_n[X] = sum_f z_f^n X_f, n = -p..p (one FFT: dt is rounded so that the lines are an
N-point grid on the circle). R_p = L_p L_p^H, with L_p the leading block of the
Cholesky factor of the largest R, so S_o^H R_p^-1 S_o is a running sum over the rows of
L^-1 S_o and every order of the sweep costs one small solve and one eigenvalue problem.

Roving-hammer tests (one accelerometer, many impacts) are fitted transposed: by reciprocity
H_jk = H_kj, so the impacts become outputs and the single accelerometer the only reference.
The caller passes the FRFs in that orientation (see ``ema.modal_fit``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cholesky, solve_triangular


@dataclass(frozen=True)
class PoleSweep:
    """Poles of every model order of an LSCF sweep, flattened over orders.

    Attributes
    ----------
    order : ndarray
        (N,) model order p that produced each pole.
    pole : ndarray
        (N,) continuous-time pole lambda = -zeta w_n + i w_d, rad/s (upper half-plane only).
    freq_hz : ndarray
        (N,) undamped natural frequency |lambda| / 2 pi, Hz.
    damping_ratio : ndarray
        (N,) -Re(lambda) / |lambda|.
    shape : ndarray
        (N, l) complex shape estimate B(z_r) L_r at the l outputs (unscaled).
    participation : ndarray
        (N, m) participation factors L_r (unit norm).
    orders : ndarray
        (n_orders,) the orders of the sweep, ascending.
    band_hz : tuple of float
        (lo, hi) band used, Hz.
    """

    order: np.ndarray
    pole: np.ndarray
    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    shape: np.ndarray
    participation: np.ndarray
    orders: np.ndarray
    band_hz: tuple[float, float]


def _toeplitz_index(p: int) -> np.ndarray:
    """Index the moment axis (n = -p..p stored at n + p) for block entry (j, k): k - j."""
    j = np.arange(p + 1)
    return (j[None, :] - j[:, None]) + p


@dataclass(frozen=True)
class _Reduced:
    """What every order needs: the blocks of the reduced normal equations and the z mapping.

    ``t_sum``: sum_o T_o, (P m, P m); ``y``: Y_o = L^-1 S_o, (P, l, P m); ``linv``: L^-1, (P, P);
    ``dt``: sampling interval of the z mapping, s; ``fc``: band centre, Hz.
    """

    t_sum: np.ndarray
    y: np.ndarray
    linv: np.ndarray
    dt: float
    fc: float


def _reduced_blocks(f: np.ndarray, h: np.ndarray, p_max: int, span: float) -> _Reduced:
    """Build the Toeplitz blocks R, S_o, T_o from the moments (one FFT) and factor R.

    dt = 1 / (N df) with N >= (F - 1) / span lines on the circle: the moments are then one
    length-N FFT, c_n = exp(-i pi n (F - 1) / N) N ifft(x)[n mod N]. R_p = L_p L_p^H with L_p
    the leading block of the full Cholesky factor, so S_o^H R_p^-1 S_o = Y_o^H Y_o with
    Y_o = L^-1 S_o restricted to rows 0..p: a running sum over the orders.

    Parameters
    ----------
    f : ndarray
        (F,) the band's lines, Hz.
    h : ndarray
        (F, l, m) the band's FRFs, outputs equalised.
    p_max : int
        Highest order.
    span : float
        Fraction of the unit circle the band covers.

    Returns
    -------
    _Reduced
        The blocks, L^-1 and the z mapping.
    """
    _, n_out, m = h.shape
    n_f = f.size
    n_fft = int(np.ceil((n_f - 1) / span))
    df = (f[-1] - f[0]) / (n_f - 1)
    n_mom = np.arange(-p_max, p_max + 1)
    phase = np.exp(-1j * np.pi * n_mom * (n_f - 1) / n_fft)[:, None]
    hh = np.conj(h)[:, :, :, None] * h[:, :, None, :]  # (F, l, m, m)
    cols = np.concatenate(
        [np.ones((f.size, 1)), h.reshape(f.size, -1), hh.reshape(f.size, -1)], axis=1
    )
    mom = phase * (np.fft.ifft(cols, n=n_fft, axis=0) * n_fft)[n_mom % n_fft]  # c_n of 1, H, H^H H
    c_s = -mom[:, 1 : 1 + n_out * m].reshape(-1, n_out, m)
    c_t = mom[:, 1 + n_out * m :].reshape(-1, n_out, m, m)
    n_p = p_max + 1
    idx = _toeplitz_index(p_max)  # (P, P)
    s_full = np.moveaxis(c_s[idx], 2, 0).reshape(n_out, n_p, n_p * m)  # S_o[j, (k, b)]
    t_sum = np.transpose(c_t[idx].sum(axis=2), (0, 2, 1, 3)).reshape(n_p * m, n_p * m)
    try:
        chol = cholesky(mom[:, 0][idx], lower=True)
    except np.linalg.LinAlgError as exc:
        raise ValueError(f"band {f[0]:g}-{f[-1]:g} Hz: LSCF normal equations are singular") from exc
    # the inverse of a leading block of a triangular matrix is the leading block of its inverse
    linv = solve_triangular(chol, np.eye(n_p), lower=True)
    y = (linv @ np.moveaxis(s_full, 0, 1).reshape(n_p, -1)).reshape(n_p, n_out, n_p * m)
    return _Reduced(t_sum, y, linv, 1.0 / (n_fft * df), 0.5 * (f[0] + f[-1]))


def _order_poles(
    red: _Reduced, yhy: np.ndarray, p: int, m: int, max_damping: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Solve the order-p model (A_p = I) and return its poles, shapes and participations.

    Parameters
    ----------
    red : _Reduced
        The blocks (``_reduced_blocks``).
    yhy : ndarray
        sum_{j <= p} Y_j^H Y_j, (P m, P m).
    p, m : int
        Model order and number of references.
    max_damping : float
        Poles with damping ratios outside (0, max_damping) are dropped.

    Returns
    -------
    lam : ndarray
        (n,) continuous poles, rad/s.
    shape : ndarray
        (n, l) shape estimates B(z_r) L_r.
    participation : ndarray
        (n, m) unit-norm participation factors L_r.
    """
    n_c = (p + 1) * m
    mm = red.t_sum[:n_c, :n_c] - yhy[:n_c, :n_c]
    top = np.linalg.solve(mm[: p * m, : p * m], -mm[: p * m, p * m :])  # (p m, m)
    alpha = np.vstack([top, np.eye(m, dtype=complex)])  # (n_c, m)
    comp = np.zeros((p * m, p * m), dtype=complex)
    comp[: (p - 1) * m, m:] = np.eye((p - 1) * m)
    # last block row: [-A_0, -A_1, ..., -A_{p-1}], A_k = top[k m:(k+1) m, :]
    comp[(p - 1) * m :, :] = -top.reshape(p, m, m).transpose(1, 0, 2).reshape(m, p * m)
    if m == 1:
        zr = np.linalg.eigvals(comp)
        vec = np.ones((1, zr.size), dtype=complex)
    else:
        zr, vec = np.linalg.eig(comp)
    lam = np.log(zr) / red.dt + 2j * np.pi * red.fc
    keep = np.isfinite(lam) & (lam.imag > 0) & (-lam.real > 0)
    keep[keep] &= -lam.real[keep] < max_damping * np.abs(lam[keep])
    lam, zr = lam[keep], zr[keep]
    lr = vec[:m, keep]
    lr = lr / np.linalg.norm(lr, axis=0, keepdims=True)
    # numerators b_o = -R_p^-1 S_o alpha = -L_p^-H (Y_o alpha)
    ya = (red.y[: p + 1, :, :n_c] @ alpha).reshape(p + 1, -1)
    beta = -np.conj(red.linv[: p + 1, : p + 1]).T @ ya
    beta = beta.reshape(p + 1, -1, m)  # b_o,k
    zk = zr[None, :] ** np.arange(p + 1)[:, None]  # (P, n_poles)
    if m == 1:
        shape = (zk.T @ beta[:, :, 0]) * lr[0][:, None]
    else:
        shape = np.einsum("kon,kn->no", beta @ lr, zk)
    return lam, shape, lr.T


def lscf_sweep(
    freq_hz: np.ndarray,
    frf: np.ndarray,
    band_hz: tuple[float, float],
    max_order: int,
    min_order: int = 2,
    span: float = 0.9,
    order_step: int = 1,
    max_damping: float = 0.3,
) -> PoleSweep:
    """Fit polyreference LSCF models of orders min_order..max_order and return their poles.

    Parameters
    ----------
    freq_hz : ndarray
        (F,) evenly spaced frequency lines, Hz.
    frf : ndarray
        (F, l, m) FRFs, l outputs by m references (any quantity; the poles do not care).
    band_hz : tuple of float
        (lo, hi) frequency band fitted, Hz.
    max_order : int
        Highest polynomial order p (p m poles at order p).
    min_order : int
        Lowest order.
    span : float
        The band is mapped onto the arc |angle z| <= span pi of the unit circle.
    order_step : int
        Fit every order_step-th order from min_order up.
    max_damping : float
        Poles with damping ratios outside (0, max_damping) are dropped.

    Returns
    -------
    PoleSweep
        The poles of positive damped frequency and damping in (0, max_damping), in the band
        or not.
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
    h = h[sel]
    m = h.shape[2]
    # Equalise the outputs: each output row contributes with unit RMS.
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=(0, 2)))
    h = h / np.where(rms > 0, rms, 1.0)[None, :, None]
    red = _reduced_blocks(freq_hz[sel], h, p_max, span)
    yhy = np.zeros((red.t_sum.shape[0],) * 2, dtype=complex)
    orders, pole_l, shape_l, part_l, order_l = [], [], [], [], []
    for p in range(0, p_max + 1):
        yhy += np.conj(red.y[p]).T @ red.y[p]
        if p < int(min_order) or (p - int(min_order)) % int(order_step):
            continue
        lam, shape, part = _order_poles(red, yhy, p, m, max_damping)
        orders.append(p)
        pole_l.append(lam)
        shape_l.append(shape)
        part_l.append(part)
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
