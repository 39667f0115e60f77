"""Pairing of two mode sets sampled at the same points, and a scaling check.

    MAC(a, b) = |a^H b|^2 / ((a^H a)(b^H b))                     (ema.shapes.mac)

``pair_modes`` assigns the modes one-to-one (Hungarian algorithm, Kuhn 1955) maximising the
summed score

    S(i, j) = MAC(a_i, b_j)                              shapes only, or
    S(i, j) = MAC(a_i, b_j) - w |ln(f_a,i / f_b,j)|      shapes and frequencies,

and then judges each pair: MAC below ``min_mac`` (or, with frequencies, a relative frequency
gap above ``max_rel_df``) makes it weak; weak pairs are dropped or raise.

Pseudo-orthogonality of test shapes scaled to unit modal mass, with the SEREP-reduced mass
M_a = T^T M T:  POC = E_a^T M_a E_a ~ I (off-diagonals show shape error, the diagonal the
scaling error).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.optimize import linear_sum_assignment

from ema.shapes.mac import mac


@dataclass(frozen=True)
class ModePairs:
    """Mode pairs of two mode sets by MAC.

    Mode ``index_a[k]`` of set a pairs with mode ``index_b[k]`` of set b with MAC ``mac[k]``;
    ascending in ``index_a``. Unpacks as ``(index_a, index_b, mac)``.
    """

    index_a: np.ndarray
    index_b: np.ndarray
    mac: np.ndarray

    def __iter__(self):
        return iter((self.index_a, self.index_b, self.mac))

    @property
    def size(self) -> int:
        """Return the number of pairs."""
        return int(self.index_a.size)


def pair_modes(
    shapes_a: np.ndarray, shapes_b: np.ndarray, *, min_mac: float = 0.5,
    freq_a_hz: np.ndarray | None = None, freq_b_hz: np.ndarray | None = None,
    max_rel_df: float | None = None, freq_weight: float = 1.0,
    weak: Literal["drop", "raise"] = "drop",
) -> ModePairs:
    """Pair the modes of two sets one-to-one, by MAC or by MAC and frequency distance.

    Parameters
    ----------
    shapes_a, shapes_b : (n_points, m_a), (n_points, m_b) arrays
        Real (or complex) shapes at the same points, any scaling and sign. Set a is the one
        being paired (the test, or the baseline), set b the candidates (model or re-test).
    min_mac : float
        A pair with MAC below this is weak.
    freq_a_hz, freq_b_hz : (m_a,), (m_b,) arrays, optional
        Natural frequencies. Given together, the assignment maximises
        MAC - ``freq_weight`` |ln(f_a / f_b)| instead of MAC alone.
    max_rel_df : float, optional
        With frequencies: a pair whose frequencies differ by more than this fraction
        (|ln(f_a / f_b)| > ln(1 + max_rel_df)) is weak. None: no frequency limit.
    freq_weight : float
        Weight w of the log-frequency distance in the score.
    weak : {"drop", "raise"}
        "drop": weak pairs are left out (modes may stay unpaired). "raise": every mode of
        set a must pair; a weak pair, or more modes in a than in b, raises ValueError.

    Returns
    -------
    ModePairs
        Index arrays into a and b (ascending in a) and the pairs' MAC values.

    References
    ----------
    Allemang, R. J. (2003), The Modal Assurance Criterion: twenty years of use and abuse,
    Sound and Vibration 37(8). Kuhn, H. W. (1955), The Hungarian method for the assignment
    problem, Naval Research Logistics Quarterly 2.
    """
    m = mac(shapes_a, shapes_b)
    if weak == "raise" and m.shape[0] > m.shape[1]:
        raise ValueError(f"{m.shape[0]} test modes but only {m.shape[1]} model modes to pair")
    with_freq = freq_a_hz is not None and freq_b_hz is not None
    if with_freq:
        dlog = np.abs(np.log(np.asarray(freq_a_hz)[:, None] / np.asarray(freq_b_hz)[None, :]))
        ia, ib = linear_sum_assignment(-(m - freq_weight * dlog))
    else:
        ia, ib = linear_sum_assignment(-m)
    order = np.argsort(ia)
    ia, ib = ia[order], ib[order]
    values = m[ia, ib]
    ok = values >= min_mac
    if with_freq and max_rel_df is not None:
        ok &= dlog[ia, ib] <= np.log1p(max_rel_df)
    if weak == "raise" and not np.all(ok):
        k = int(np.flatnonzero(~ok)[0])
        raise ValueError(f"test mode {ia[k] + 1} pairs with no model mode (best MAC "
                         f"{values[k]:.2f} < {min_mac})")
    return ModePairs(ia[ok], ib[ok], values[ok])


def align_signs(reference: np.ndarray, shapes: np.ndarray) -> np.ndarray:
    """Flip columns of ``shapes`` so that each has a non-negative dot product with reference."""
    s = np.sign(np.sum(reference * shapes, axis=0))
    return shapes * np.where(s == 0, 1.0, s)


@dataclass(frozen=True)
class Orthogonality:
    """POC matrix and its worst deviations from I."""

    poc: np.ndarray
    max_offdiag: float
    max_diag_error: float


def pseudo_orthogonality(shapes_a: np.ndarray, reduced_mass: np.ndarray) -> Orthogonality:
    """Pseudo-orthogonality check POC = E_a^T M_a E_a of the test shapes' scaling.

    Parameters
    ----------
    shapes_a : (a, m) array
        Measured shapes at the SEREP DOFs, scaled to unit modal mass.
    reduced_mass : (a, a) array
        The SEREP-reduced reference mass M_a = T^T M T (``Serep.reduce``).

    Returns
    -------
    Orthogonality
        POC (m, m), its largest off-diagonal magnitude and largest |diag - 1|.
    """
    poc = shapes_a.T @ reduced_mass @ shapes_a
    off = poc - np.diag(np.diag(poc))
    return Orthogonality(poc, float(np.max(np.abs(off), initial=0.0)),
                         float(np.max(np.abs(np.diag(poc) - 1.0))))


def paired_elastic(model_shapes: np.ndarray, test_shapes: np.ndarray, dofs: np.ndarray,
                   n_rigid: int, spare: int = 6) -> np.ndarray:
    """Index of the model mode paired (by MAC at ``dofs``) with each test mode.

    Parameters
    ----------
    model_shapes : (n_dof, k) array
        The model's modes, ascending, the first ``n_rigid`` rigid (or suspension) ones.
    test_shapes : (a, m) array
        Measured shapes at the translational DOFs ``dofs`` (a,).
    n_rigid : int
        Leading model modes that are never candidates.
    spare : int
        Candidates beyond the m lowest elastic model modes (a mode pushed up the order).

    Returns
    -------
    (m,) int array
        Column of ``model_shapes`` for each test mode; ValueError if one pairs with none
        (``pair_modes`` with weak="raise").
    """
    m = test_shapes.shape[1]
    cand = np.arange(n_rigid, min(model_shapes.shape[1], n_rigid + m + spare))
    pairs = pair_modes(test_shapes, model_shapes[np.ix_(dofs, cand)], weak="raise")
    return cand[pairs.index_b]
