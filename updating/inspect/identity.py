"""Which bending plane each paired mode is, and which modes may carry a verdict.

A bat's bending modes come in pairs, one per grain plane, split by 0.3 % (mode 1) to about
6 % (mode 6). A hammer and accelerometer at an angle theta to plane 1 see plane 1's member
with mass-normalised shape cos(theta) phi and plane 2's with sin(theta) phi; a resolved pair
is merged into one mode of amplitude sqrt(cos^2 + sin^2) = 1 times phi
(``updating.correlate.planes.merge_plane_pairs``), and a pair too close to resolve is one
peak of the same full amplitude. So each paired mode's amplitude against the reference's,

    rho_r = ||psi_r|| / ||phi_model,r||   over the test points, divided by its median over
                                          the paired modes (the calibration's common scale),

tells what the test saw of it: about 1 for both planes (merged, or one peak holding both)
or the dominant plane's member alone; cos(theta) or sin(theta) < 1 for one plane's member
alone. A mode whose amplitude is below the others' in either test is one plane's member
alone: below ``MINOR_MAX`` the weaker plane's, up to ``DOMINANT_MIN`` one of two planes
tapped near the diagonal that cannot be told apart. Its changes follow that plane's shear
stiffness, not the merged planes' the reference was calibrated to, so it is left out of the
verdict. The band's top can cut a pair: a mode seen once within the largest plane split of
the top (``PLANE_SPLIT_MAX_REL`` for its order) may have its partner above the band, which
is how a lone member of the weaker plane comes to be the band's last mode; the note says so.
A band-cut mode at full amplitude is the dominant plane's (or both) and is kept.

One mode of the wrong plane made an accusation (a legally gripped maple bat, tapped 17-20
deg off the grain plane, 0-3.2 kHz: its sixth mode was the second plane's member, the
first plane's lying above the band, and read as a core at the barrel end).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

PLANE_SPLIT_MAX_REL = (0.008, 0.025, 0.04, 0.05, 0.075, 0.09)
"""Largest split of the two bending planes' frequencies expected for elastic modes 1-6
(relative; beyond mode 6 the last value): 1.6 x the 3D analysis of a smooth ash bat (0.3,
1.3, 2.3, 3.0, 4.7, 5.6 %), for woods whose planes' shear moduli differ more."""
MINOR_MAX = 0.6
"""Relative amplitude below which a mode is one plane's member alone, the weaker one (a
member seen alone has cos(theta) or sin(theta); the weaker is below 0.71, and below 0.6 for
a tap more than 8 deg from the diagonal)."""
DOMINANT_MIN = 0.85
"""Relative amplitude from which a mode seen once is the dominant plane's member or both
planes in one peak (a tap within 32 deg of a grain plane)."""


@dataclass(frozen=True)
class ModeIdentity:
    """What each paired mode is, by test, and which modes the verdict uses.

    Attributes
    ----------
    amplitude_baseline, amplitude_retest : numpy.ndarray
        (m,) each paired mode's relative amplitude ``rho`` in the two tests (module
        docstring).
    band_cut : numpy.ndarray
        (m,) bool: a mode seen once whose other plane's member may lie above the band's top
        in either test.
    usable : numpy.ndarray
        (m,) bool: the modes the verdict is judged on.
    notes : tuple of str
        One line per mode left out, saying why (for the verdict's reasons).
    labels : tuple of str
        Each mode the verdict is judged on in the lab's words (``mode_label``).
    """

    amplitude_baseline: np.ndarray
    amplitude_retest: np.ndarray
    band_cut: np.ndarray
    usable: np.ndarray
    notes: tuple[str, ...] = ()
    labels: tuple[str, ...] = ()


def mode_label(order: int, freq_hz: float) -> str:
    """Name a mode as the lab does: "mode 3 (1120 Hz)" (1-based elastic order, its frequency)."""
    return f"mode {int(order) + 1} ({freq_hz:.0f} Hz)"


def relative_amplitude(shapes: np.ndarray, model_shapes: np.ndarray) -> np.ndarray:
    """Return each mode's amplitude against the model's, over its median (``rho``).

    Parameters
    ----------
    shapes : numpy.ndarray
        (n_points, m) a test's mass-normalised shapes of the paired modes, 1/sqrt(kg).
    model_shapes : numpy.ndarray
        (n_points, m) the reference's paired shapes at the same points, 1/sqrt(kg).

    Returns
    -------
    numpy.ndarray
        (m,) ||psi_r|| / ||phi_r|| divided by its median over the modes.
    """
    ratio = np.linalg.norm(shapes, axis=0) / np.maximum(np.linalg.norm(model_shapes, axis=0),
                                                        1e-300)
    mid = float(np.median(ratio))
    return ratio / mid if mid > 0 else ratio


def band_cut(freq_hz: np.ndarray, order: np.ndarray, members: np.ndarray | None,
             band_top_hz: float | None) -> np.ndarray:
    """Tell which modes seen once may have their partner above the band's top.

    Parameters
    ----------
    freq_hz : numpy.ndarray
        (m,) the modes' frequencies in one test, Hz.
    order : numpy.ndarray
        (m,) their 0-based order among the elastic modes (``PLANE_SPLIT_MAX_REL``).
    members : numpy.ndarray or None
        (m,) 2 for a merged pair (both planes seen), 1 for a mode seen once; None: unknown
        (every mode taken as seen once).
    band_top_hz : float or None
        The top of the fitted band, Hz; None: unknown (nothing is cut).

    Returns
    -------
    numpy.ndarray
        (m,) bool.
    """
    f = np.asarray(freq_hz, dtype=float)
    if band_top_hz is None:
        return np.zeros(f.size, dtype=bool)
    split = np.asarray(PLANE_SPLIT_MAX_REL)[np.minimum(np.asarray(order, int),
                                                       len(PLANE_SPLIT_MAX_REL) - 1)]
    once = np.ones(f.size, bool) if members is None else np.asarray(members) < 2
    return once & (f * (1 + split) > band_top_hz)


def mode_identity(freq_hz: np.ndarray, order: np.ndarray, shapes_b: np.ndarray,
                  shapes_r: np.ndarray, model_shapes: np.ndarray, *,
                  members_b: np.ndarray | None = None, members_r: np.ndarray | None = None,
                  band_top_b_hz: float | None = None,
                  band_top_r_hz: float | None = None) -> ModeIdentity:
    """Identify each paired mode's plane content and leave out what cannot carry a verdict.

    Parameters
    ----------
    freq_hz : numpy.ndarray
        (m,) the paired modes' baseline frequencies, Hz (for the notes and the band).
    order : numpy.ndarray
        (m,) their 0-based order among the reference's elastic modes.
    shapes_b, shapes_r : numpy.ndarray
        (n_points, m) the paired modes' mass-normalised shapes in the baseline and re-test.
    model_shapes : numpy.ndarray
        (n_points, m) the reference's paired shapes at the points.
    members_b, members_r : numpy.ndarray or None
        (m,) merged pairs (2) and modes seen once (1) of each test, None: unknown.
    band_top_b_hz, band_top_r_hz : float or None
        The top of each test's fitted band, Hz, None: unknown.

    Returns
    -------
    ModeIdentity
        Amplitudes, the band's cuts and the modes kept (module docstring).
    """
    f, order = np.asarray(freq_hz, dtype=float), np.asarray(order, dtype=int)
    rho_b = relative_amplitude(shapes_b, model_shapes)
    rho_r = relative_amplitude(shapes_r, model_shapes)
    cut = band_cut(f, order, members_b, band_top_b_hz) | \
        band_cut(f, order, members_r, band_top_r_hz)
    low = np.minimum(rho_b, rho_r)
    minor = low < MINOR_MAX
    untold = ~minor & (low < DOMINANT_MIN)
    notes = []
    for k in np.flatnonzero(minor | untold):
        name = mode_label(order[k], f[k])
        what = "the weaker one" if minor[k] else "and which plane it is cannot be told"
        beyond = ", its partner perhaps above the band's top" if cut[k] else ""
        notes.append(f"{name} left out of the verdict: only one bending plane's member was "
                     f"seen, {what} (amplitude {low[k]:.2f} of the model's{beyond}); the "
                     "model of the merged planes cannot pair it")
    usable = ~(minor | untold)
    labels = tuple(mode_label(o, fk) for o, fk in zip(order[usable], f[usable], strict=True))
    return ModeIdentity(rho_b, rho_r, cut, usable, tuple(notes), labels)
