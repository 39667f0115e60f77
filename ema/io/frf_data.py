"""The in-memory form of one impact test, used by every stage after the file readers.

FRFs are stored as ``frf[k, i, j] = H(f_k)`` for response node ``response_nodes[i]`` and
reference (impact) node ``reference_nodes[j]``, in SI units: accelerance in (m/s^2)/N,
mobility in (m/s)/N, receptance in m/N. Positions are metres along the bat axis from the
knob end.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

QUANTITIES = ("accelerance", "mobility", "receptance")


@dataclass(frozen=True)
class FrfTest:
    """One test: an evenly spaced frequency axis and an FRF matrix by response/reference node.

    Attributes
    ----------
    freq_hz : np.ndarray
        (F,) frequency lines, Hz, evenly spaced.
    frf : np.ndarray
        (F, n_resp, n_ref) complex FRFs in SI units of ``quantity``.
    response_nodes : np.ndarray
        (n_resp,) node numbers of the responses (accelerometers).
    reference_nodes : np.ndarray
        (n_ref,) node numbers of the references (hammer impacts).
    node_x_m : dict[int, float]
        node number -> position along the bat axis from the knob end, m.
    quantity : str
        "accelerance", "mobility" or "receptance".
    coherence : np.ndarray | None
        optional (F, n_resp, n_ref) ordinary coherence, 0..1.
    exp_window_tau_s : float | None
        time constant of an exponential window applied to the response
        (and force) before the FRF was estimated, s; None when no window was used.
    meta : dict
        free-form descriptive information (serial, date, source file, ...).
    """

    freq_hz: np.ndarray
    frf: np.ndarray
    response_nodes: np.ndarray
    reference_nodes: np.ndarray
    node_x_m: dict[int, float]
    quantity: str = "accelerance"
    coherence: np.ndarray | None = None
    exp_window_tau_s: float | None = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        f = np.asarray(self.freq_hz, dtype=float)
        h = np.asarray(self.frf, dtype=complex)
        if h.ndim != 3 or h.shape[0] != f.size:
            raise ValueError(f"FRF array shape {h.shape} does not match {f.size} frequency lines")
        if h.shape[1] != len(self.response_nodes) or h.shape[2] != len(self.reference_nodes):
            raise ValueError("FRF array shape does not match the response/reference node lists")
        if self.quantity not in QUANTITIES:
            raise ValueError(f"unknown FRF quantity {self.quantity!r}")
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "frf", h)
        object.__setattr__(self, "response_nodes", np.asarray(self.response_nodes, dtype=int))
        object.__setattr__(self, "reference_nodes", np.asarray(self.reference_nodes, dtype=int))

    @property
    def driving_point(self) -> tuple[int, int]:
        """(response index, reference index) of the first FRF whose two nodes coincide."""
        for i, r in enumerate(self.response_nodes):
            hits = np.flatnonzero(self.reference_nodes == r)
            if hits.size:
                return i, int(hits[0])
        raise ValueError("test has no driving-point FRF (no reference node equals a response node)")

    def x_m(self, nodes: np.ndarray) -> np.ndarray:
        """Positions (m) of the given node numbers."""
        return np.array([self.node_x_m[int(n)] for n in nodes], dtype=float)
