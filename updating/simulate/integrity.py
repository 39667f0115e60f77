"""Data-integrity slips a lab makes with a re-test file, applied to a simulated test.

- ``receptance_as_accelerance``: the analyser exported receptance (m/N) and the file says
  accelerance: H_file = H_acc / (-w^2) (the 0 Hz line, infinite in receptance, is copied
  from the next line).
- ``g_per_n_as_si``: the FRF is in g/N and the file says (m/s^2)/N: H_file = H_acc / g0.
- ``other_bat`` and ``no_barrel_points`` are set up by the case generator (another bat's
  re-test under this bat's baseline; a layout with no point between 16 and 34 in).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Literal, get_args

import numpy as np

from ema.io.frf_data import FrfTest
from updating.model.units import G0_M_S2

Integrity = Literal["receptance_as_accelerance", "g_per_n_as_si", "other_bat",
                    "no_barrel_points"]
"""A data-integrity slip of a re-test file (or of its layout)."""
INTEGRITY: tuple[Integrity, ...] = get_args(Integrity)


def receptance_labelled_accelerance(test: FrfTest) -> FrfTest:
    """Re-express the accelerance test as receptance, still labelled accelerance."""
    w2 = (2 * np.pi * test.freq_hz) ** 2
    h = np.empty_like(test.frf)
    pos = w2 > 0
    h[pos] = test.frf[pos] / -w2[pos, None, None]
    if (~pos).any():
        h[~pos] = h[np.flatnonzero(pos)[0]]
    return replace(test, frf=h)


def g_per_n_labelled_si(test: FrfTest) -> FrfTest:
    """Convert the accelerance test to g/N, labelled SI."""
    return replace(test, frf=test.frf / G0_M_S2)


def corrupt(test: FrfTest, integrity: Integrity | None) -> FrfTest:
    """Apply a file-level slip (None, ``other_bat`` and ``no_barrel_points``: unchanged)."""
    if integrity == "receptance_as_accelerance":
        return receptance_labelled_accelerance(test)
    if integrity == "g_per_n_as_si":
        return g_per_n_labelled_si(test)
    if integrity is not None and integrity not in INTEGRITY:
        raise ValueError(f"unknown integrity case {integrity!r}")
    return test
