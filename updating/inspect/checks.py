"""Checks made before any verdict, that the two tests can be compared at all.

Can the two tests be compared at all? Checks made before any verdict (three-way verdict,
../docs/inspection.md). Each returns a plain one-line reason saying what to do, or None.
None of these ever makes a bat "altered": a failed check makes the verdict inconclusive.
"""

from __future__ import annotations

import numpy as np

from updating.model.units import IN_TO_M

MIN_PAIRS = 3
AMPLITUDE_MAX_LOG = 0.10
"""Largest common log-scale between the re-test's and the baseline's mass-normalised shapes
(|ln c|): moisture (+-2.5 % mass) moves it by ~1 %, a core by a few %; a units or
calibration slip of the FRF by a factor k moves it by ln(k)/2 (g/N read as SI: -1.14)."""
AMPLITUDE_MAX_SLOPE = 0.25
"""Largest trend of that log-scale with ln f: receptance labelled accelerance puts a factor
1/w^2 on the FRF, so a slope of -1 on the shapes; drift and cores give a few hundredths."""
FREQ_MAX_LOG = 0.08
"""Largest median |ln(f_retest / f_baseline)| of one bat re-tested: moisture +-2.5 points
and +-10 C move f by at most ~4 %, a core by a few %; another bat of the same model differs
by 5-7 %."""
WEIGHT_MAX_LOG = 0.25
"""Largest |ln(W_retest / W_registered)| of one bat: moisture 2.5 %, the biggest cores and
plugs 10-15 % (a 1.25 x 12 in cork core takes out about 13 %)."""
BARREL_REACH_IN = 12.0
MAX_BARREL_GAP_IN = 5.0
"""The outer 12 in (the barrel, where cores are drilled) must have test points no further
apart than 5 in, and one within 5 in of the barrel end."""


def pairing_reason(n_pairs: int) -> str | None:
    """Say why too few modes pair (None when enough do)."""
    if n_pairs >= MIN_PAIRS:
        return None
    return (f"only {n_pairs} modes pair between baseline, re-test and the model (need "
            f"{MIN_PAIRS}): re-test with the hammer and accelerometer in the baseline's "
            "grain plane (on the label) and the same band, then inspect again")


def amplitude_reason(psi_b: np.ndarray, psi_r: np.ndarray, freq_hz: np.ndarray) -> str | None:
    """psi_b, psi_r (n_points, m) paired shapes (signs aligned), freq_hz (m,) baseline."""
    c = np.einsum("ij,ij->j", psi_r, psi_b) / np.einsum("ij,ij->j", psi_b, psi_b)
    if np.any(c <= 0):
        return ("the re-test's mode shapes have no consistent scale against the baseline's: "
                "check the accelerometer's sign, channel and units, then re-test")
    a = np.log(c)
    lf = np.log(freq_hz / freq_hz[0])
    slope, level = np.polyfit(lf, a, 1) if np.ptp(lf) > 0.5 else (0.0, float(np.mean(a)))
    if abs(slope) > AMPLITUDE_MAX_SLOPE:
        return (f"the re-test's amplitudes drift against the baseline's as f^{2 * slope:+.1f} "
                "(FRF), as a receptance or mobility file labelled accelerance would: "
                "export the re-test as accelerance, (m/s^2)/N, and inspect again")
    mid = float(np.median(a))
    if abs(mid) > AMPLITUDE_MAX_LOG:
        k = np.exp(2 * mid)
        hint = " (9.81: g/N labelled SI?)" if abs(np.log(k * 9.81)) < 0.15 or \
            abs(np.log(k / 9.81)) < 0.15 else ""
        return (f"the re-test's FRF amplitudes are {k:.3g} times the baseline's{hint}, far "
                "beyond any drift of the wood: check the units and the accelerometer's and "
                "hammer's sensitivities, then inspect again")
    return None


def identity_reason(dlnf: np.ndarray, dlnw: float | None) -> str | None:
    """Say whether the re-test looks like the same bat (frequencies, weight)."""
    mid = float(np.median(dlnf))
    if abs(mid) > FREQ_MAX_LOG:
        return (f"the re-test's frequencies differ from the baseline's by {100 * mid:+.1f} % "
                "(median), more than moisture, temperature or a core can: check that the "
                "re-test is of this bat (serial) and at the baseline's set-up")
    if dlnw is not None and abs(dlnw) > WEIGHT_MAX_LOG:
        return (f"the re-test weight differs from the registered weight by "
                f"{100 * np.expm1(dlnw):+.1f} %, more than any drift or core: check the "
                "scale and that this is the registered bat")
    return None


def coverage_reason(points_m: np.ndarray, length_m: float) -> str | None:
    """Say whether the test points can see the barrel."""
    x = np.sort(np.asarray(points_m, dtype=float)) / IN_TO_M
    L = length_m / IN_TO_M
    start = L - BARREL_REACH_IN
    inside = x[x >= start]
    edges = np.concatenate([[start], inside, [L]])
    gaps = np.diff(edges)
    if inside.size < 2 or gaps[1:-1].max(initial=0.0) > MAX_BARREL_GAP_IN or \
            gaps[0] > MAX_BARREL_GAP_IN or gaps[-1] > MAX_BARREL_GAP_IN:
        return (f"the test points cannot see the barrel ({inside.size} in its outer "
                f"{BARREL_REACH_IN:.0f} in, largest gap {gaps.max():.1f} in): register and "
                f"re-test with points at most {MAX_BARREL_GAP_IN:.0f} in apart there")
    return None
