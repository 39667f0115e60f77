"""Two bending planes: one 1D mode from a resolved pair (../docs/inspection.md).

Wood's shear modulus differs between the radial and tangential planes, so each bending mode
of a bat is a pair split by 0.3 % (mode 1) to ~6 % (mode 6). A hammer and accelerometer at
an angle theta to a grain plane excite both: the FRF is cos^2 H_R + sin^2 H_T, and a modal
fit that resolves the pair returns two modes with mass-normalised shapes psi_R ~ cos(theta)
phi, psi_T ~ sin(theta) phi (nearly the same shape phi). A planar beam model has one mode
there. ``merge_plane_pairs`` replaces each resolved pair by that one mode:

    a_k = rms(psi_k),  f = (a_R^2 f_R + a_T^2 f_T) / (a_R^2 + a_T^2),
    psi = (a_R psi_R + a_T psi_T) / sqrt(a_R^2 + a_T^2)      (psi_T sign-aligned to psi_R)

which is phi with the frequency an unresolved fit would give (the members' mean weighted by
their share of the response). A re-test tapped at another angle moves that weighting: the
inspection treats the resulting frequency change as a nuisance
(``updating.inspect.hypotheses.plane_shift``).

The merged modes keep the members' own frequencies (``MeasuredModes.plane_pair_hz``, lower
and upper, with their uncertainties): the change of a pair's split between the tests reads a
flat (``updating.inspect.plane_split``).
"""

from __future__ import annotations

import numpy as np

from updating.correlate.measured import MeasuredModes

PAIR_MAX_REL_DF = 0.08
"""Two modes this close in frequency ..."""
PAIR_MIN_MAC = 0.8
"""... with shapes this alike are the two planes of one bending mode."""


def _mac(a: np.ndarray, b: np.ndarray) -> float:
    return float((a @ b) ** 2 / ((a @ a) * (b @ b)))


def merge_plane_pairs(modes: MeasuredModes) -> MeasuredModes:
    """Merge each resolved two-plane pair into one mode.

    The modes with each resolved two-plane pair (adjacent, within ``PAIR_MAX_REL_DF``,
    MAC >= ``PAIR_MIN_MAC``) replaced by one mode (module docstring); ``members`` says
    which modes were merged (2) and which were seen once (1), ``plane_pair_hz`` and
    ``plane_pair_std_hz`` the merged members' own frequencies; the band's top is kept.
    """
    f, psi = np.asarray(modes.freq_hz, float), np.asarray(modes.shapes, float)
    std = None if modes.freq_std_hz is None else np.asarray(modes.freq_std_hz, float)
    was = np.ones(f.size, int) if modes.members is None else np.asarray(modes.members, int)
    noise = None if modes.shape_noise_rel is None else np.asarray(modes.shape_noise_rel, float)
    out_f, out_psi, out_z, out_std, out_members, out_noise = [], [], [], [], [], []
    nan2 = np.full(2, np.nan)
    pair_hz, pair_std = [], []
    k = 0
    while k < f.size:
        if k + 1 < f.size and f[k + 1] / f[k] - 1 < PAIR_MAX_REL_DF and \
                _mac(psi[:, k], psi[:, k + 1]) >= PAIR_MIN_MAC:
            p1, p2 = psi[:, k], psi[:, k + 1]
            p2 = p2 * np.sign(p1 @ p2)
            a1, a2 = np.sqrt(np.mean(p1**2)), np.sqrt(np.mean(p2**2))
            w1, w2 = a1**2 / (a1**2 + a2**2), a2**2 / (a1**2 + a2**2)
            out_f.append(w1 * f[k] + w2 * f[k + 1])
            out_psi.append((a1 * p1 + a2 * p2) / np.hypot(a1, a2))
            out_z.append(w1 * modes.damping_ratio[k] + w2 * modes.damping_ratio[k + 1])
            if std is not None:
                out_std.append(max(std[k], std[k + 1]))
            if noise is not None:  # the merged shape's entries: weights a_i / hypot(a1, a2)
                out_noise.append(np.sqrt(w1 * noise[k] ** 2 + w2 * noise[k + 1] ** 2))
            out_members.append(was[k] + was[k + 1])
            pair_hz.append(f[k:k + 2])
            pair_std.append(nan2 if std is None else std[k:k + 2])
            k += 2
        else:
            out_f.append(f[k])
            out_psi.append(psi[:, k])
            out_z.append(modes.damping_ratio[k])
            if std is not None:
                out_std.append(std[k])
            if noise is not None:
                out_noise.append(noise[k])
            out_members.append(was[k])
            pair_hz.append(nan2)
            pair_std.append(nan2)
            k += 1
    return MeasuredModes(np.array(out_f), np.column_stack(out_psi), modes.x_m,
                         np.array(out_z), modes.sensor_x_m,
                         None if std is None else np.array(out_std),
                         band_top_hz=modes.band_top_hz,
                         members=np.array(out_members, dtype=int),
                         plane_pair_hz=np.array(pair_hz, dtype=float).reshape(-1, 2),
                         plane_pair_std_hz=np.array(pair_std, dtype=float).reshape(-1, 2),
                         shape_noise_rel=None if noise is None else np.array(out_noise))
