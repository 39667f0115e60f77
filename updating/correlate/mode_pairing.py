"""Pairing of modes between two sets of shapes at the same points (MAC and frequency).

    MAC(a, b) = (a^T b)^2 / ((a^T a)(b^T b))

Pairs maximise the summed score MAC - w |ln(f_a / f_b)| over one-to-one assignments
(Hungarian algorithm); pairs below ``min_mac`` or further apart than ``max_rel_df`` are
dropped.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from ema.shapes.mac import mac


def pair_modes(
    freq_a: np.ndarray, shapes_a: np.ndarray, freq_b: np.ndarray, shapes_b: np.ndarray,
    min_mac: float = 0.8, max_rel_df: float = 0.15, freq_weight: float = 1.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Indices (ia, ib) of paired modes, ascending in ia, and their MAC values."""
    m = mac(shapes_a, shapes_b)
    dlog = np.abs(np.log(np.asarray(freq_a)[:, None] / np.asarray(freq_b)[None, :]))
    ia, ib = linear_sum_assignment(-(m - freq_weight * dlog))
    ok = (m[ia, ib] >= min_mac) & (dlog[ia, ib] <= np.log1p(max_rel_df))
    ia, ib = ia[ok], ib[ok]
    order = np.argsort(ia)
    return ia[order], ib[order], m[ia[order], ib[order]]
