"""Checks and assembly shared by the FRF file readers (UFF, CSV).

One frequency axis, an even spacing, finite values, a full response x reference matrix of
FRFs, and FRFs that hold a signal at a scale double precision can fit.
"""

from __future__ import annotations

import numpy as np

SCALE_RANGE = (1e-15, 1e15)
"""Accepted largest |H| of a test, SI: any structure's accelerance, mobility or receptance
lies well inside (a bat's accelerance peaks at 10-1000 (m/s^2)/N, a stiff machine's
receptance at 1e-11 m/N); beyond, the file's units or scale are wrong, and a fit's sums of
squares would overflow or underflow."""
DEAD_REL = 1e-9
"""An FRF whose largest |H| is below this fraction of the test's largest holds no signal (a
missed hit, a dead channel, a zeroed column)."""
EVEN_TOL = 0.05
"""Largest deviation of a frequency line from the even grid f0 + k df, as a fraction of df.

Generous enough for axes printed with 6 significant digits (UFF E13.5), tight enough to
catch a missing or extra line."""


def even_axis(freq_hz: np.ndarray, where: str) -> tuple[float, float]:
    """Return (f0, df) of an evenly spaced, increasing axis; ValueError naming ``where`` if not.

    The grid is f_k = f0 + k df with f0 = f[0] and df = (f[-1] - f[0]) / (n - 1) or f[1] - f[0],
    whichever fits better (so that axes built as f0 + arange(n) * df come back bit for bit);
    every line must lie within EVEN_TOL * df of it.
    """
    f = np.asarray(freq_hz, dtype=float)
    if f.size < 2:
        raise ValueError(f"{where}: frequency axis has {f.size} line(s), at least 2 needed")
    if not np.all(np.isfinite(f)):
        raise ValueError(f"{where}: frequency axis contains NaN or inf")
    df = (f[-1] - f[0]) / (f.size - 1)
    if not df > 0:
        raise ValueError(f"{where}: frequency axis is not increasing")
    k_lines = np.arange(f.size)
    dev = np.abs(f - (f[0] + k_lines * df))
    step = f[1] - f[0]  # reproduces arange(n) * df exactly where the end-point slope does not
    dev_step = np.abs(f - (f[0] + k_lines * step))
    if dev_step.max() < dev.max():
        df, dev = step, dev_step
    k = int(np.argmax(dev))
    if dev[k] > EVEN_TOL * df:
        raise ValueError(
            f"{where}: uneven frequency spacing (line {k} at {f[k]:.6g} Hz is "
            f"{dev[k] / df:.3g} lines off the even grid {f[0]:.6g} + k*{df:.6g} Hz)"
        )
    return float(f[0]), float(df)


def same_axis(a: tuple[int, float, float], b: tuple[int, float, float]) -> bool:
    """Tell whether two axes (n, f0, df) agree: same line count, f0 and df within 1e-6 df."""
    (na, f0a, dfa), (nb, f0b, dfb) = a, b
    tol = 1e-6 * max(dfa, dfb)
    return na == nb and abs(f0a - f0b) <= tol and abs(dfa - dfb) <= tol / max(na, 1)


def require_finite(values: np.ndarray, where: str) -> None:
    """Raise ValueError naming ``where`` and the first bad line if ``values`` holds NaN/inf."""
    bad = ~np.isfinite(values)
    if bad.any():
        k = int(np.flatnonzero(bad.reshape(bad.shape[0], -1).any(axis=1))[0])
        raise ValueError(f"{where}: NaN or inf in the data (first at frequency line {k})")


def assemble(
    pairs: list[tuple[int, int]], columns: list[np.ndarray], where: str, what: str = "FRF"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stack per-pair columns (F,) into (F, n_resp, n_ref).

    Node order is the order of first appearance. Every response/reference combination must
    appear exactly once; ValueError naming ``where`` otherwise.
    """
    resp = list(dict.fromkeys(p[0] for p in pairs))
    ref = list(dict.fromkeys(p[1] for p in pairs))
    ri = {n: i for i, n in enumerate(resp)}
    fi = {n: j for j, n in enumerate(ref)}
    out = np.full((columns[0].shape[0], len(resp), len(ref)), np.nan, dtype=columns[0].dtype)
    seen = np.zeros((len(resp), len(ref)), dtype=bool)
    for (r, f), col in zip(pairs, columns, strict=True):
        i, j = ri[r], fi[f]
        if seen[i, j]:
            raise ValueError(f"{where}: two {what}s for response node {r} / reference node {f}")
        seen[i, j] = True
        out[:, i, j] = col
    if not seen.all():
        i, j = np.argwhere(~seen)[0]
        raise ValueError(
            f"{where}: no {what} for response node {resp[i]} / reference node {ref[j]} "
            "(the FRFs must form a full response x reference matrix)"
        )
    return np.array(resp, dtype=int), np.array(ref, dtype=int), out


def require_signal(frf: np.ndarray, response_nodes, reference_nodes, where: str) -> None:
    """Raise ValueError naming ``where`` unless every FRF holds a signal at a usable scale.

    The test's largest |H| must lie within ``SCALE_RANGE`` and each FRF's largest |H| must
    reach ``DEAD_REL`` of it (an all-zero FRF is refused by name: its response and
    reference nodes).

    Parameters
    ----------
    frf : numpy.ndarray
        (F, n_resp, n_ref) FRFs, SI, finite.
    response_nodes, reference_nodes : sequence of int
        The node numbers of the FRF matrix's rows and columns.
    where : str
        The file, for the message.
    """
    peak = np.abs(frf).max(axis=0)  # (n_resp, n_ref)
    top = float(peak.max(initial=0.0))
    if top == 0.0:
        raise ValueError(f"{where}: every FRF is zero at every line (no signal)")
    lo, hi = SCALE_RANGE
    if not lo <= top <= hi:
        raise ValueError(f"{where}: the FRFs' largest magnitude is {top:.3g} (SI), outside "
                         f"{lo:g}-{hi:g}: check the file's units and scale")
    dead = np.argwhere(peak < DEAD_REL * top)
    if dead.size:
        i, j = dead[0]
        raise ValueError(f"{where}: the FRF of response node {int(response_nodes[i])} / "
                         f"reference node {int(reference_nodes[j])} is zero at every line "
                         f"({len(dead)} such FRF(s): a missed hit or a dead channel)")
