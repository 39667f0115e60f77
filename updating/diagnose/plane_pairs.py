"""Which bending plane each measured mode belongs to, and which peaks hold both planes.

Wood's two bending planes differ in shear stiffness, so every bending pair splits the same
way: the stiffer plane's member is the higher one in every pair. Plane 1 is the stiffer plane
(for wood the radial, L-R plane): the higher member of every split pair, whatever the
amplitudes, and the tap angle theta is measured from it (above 45 degrees when the tap is
nearer plane 2). By amplitude (the larger member plane 1's) noise swapped the planes from
one pair to the next when tapped at 45 degrees, where the amplitudes tie.

A mode seen once is either one plane's member (the other was not found) or a peak holding
both (a split below its half-power width, fitted as one mode). Their amplitudes tell them
apart: a peak holding both carries the pair's full amplitude, sqrt(|y_1|^2 + |y_2|^2) of a
split pair, a member cos(theta) or sin(theta) of it, with tan(theta) the median amplitude
ratio of the split pairs. Each mode's amplitude is compared with the model's (mass-normalised,
so the ratio is the same for every mode up to the model's error), scaled by the median ratio
kappa of the split pairs' full amplitude to the model's; a mode seen once holds both planes
when its ratio exceeds the geometric mean of the larger member's, max(cos, sin), and 1.
"""

from __future__ import annotations

import numpy as np

PLANE_1, PLANE_2, SEEN_ONCE, BOTH_IN_ONE = 0, 1, 2, 3


def plane_codes(
    freq_hz: np.ndarray, norm: np.ndarray, model_index: np.ndarray, model_norm: np.ndarray,
) -> np.ndarray:
    """Assign every paired measured mode its plane code (module docstring).

    Parameters
    ----------
    freq_hz : ndarray
        (m,) measured frequencies, Hz.
    norm : ndarray
        (m,) their shapes' norms over the test points, 1/sqrt(kg).
    model_index : ndarray
        (m,) the model mode each is paired with (two members of a split pair share one).
    model_norm : ndarray
        The model's shape norms over the test points, per model mode, 1/sqrt(kg).

    Returns
    -------
    ndarray
        (m,) ``PLANE_1`` / ``PLANE_2``: a split pair's member; ``SEEN_ONCE``: one plane's
        member alone; ``BOTH_IN_ONE``: a peak holding both planes' members.
    """
    code = np.full(freq_hz.size, SEEN_ONCE)
    pairs = [np.flatnonzero(model_index == r) for r in np.unique(model_index)]
    pairs = [p[np.argsort(freq_hz[p])] for p in pairs if p.size == 2]  # (low, high)
    if not pairs:
        return code
    two, one = np.array(pairs).T
    code[one], code[two] = PLANE_1, PLANE_2
    kappa = np.median(np.hypot(norm[one], norm[two]) / model_norm[model_index[one]])
    theta = np.arctan(np.median(norm[two] / norm[one]))
    larger = max(np.cos(theta), np.sin(theta))
    once = np.flatnonzero(code == SEEN_ONCE)
    ratio = norm[once] / (kappa * model_norm[model_index[once]])
    code[once[ratio > np.sqrt(larger)]] = BOTH_IN_ONE
    return code
