"""A test's modal fit as the updating stage's measured modes (one mode per bending pair).

The automatic modal analysis (``ema.modal_fit.fit_test``, polyreference LSCF) gives the
test's modes; ``measured.from_fit`` keeps the elastic ones as mass-normalised shapes at the
points, and ``planes.merge_plane_pairs`` replaces each resolved pair of bending planes by
the one mode a planar beam model has.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ema.modal_fit import fit_test
from updating.correlate.measured import MeasuredModes, from_fit
from updating.correlate.planes import merge_plane_pairs
from updating.correlate.points import sensor_x_m

if TYPE_CHECKING:
    from ema.io.frf_data import FrfTest
    from ema.modal_fit import ModalFit


def fit_measured(test: FrfTest, known_mass_kg: float | None = None
                 ) -> tuple[ModalFit, MeasuredModes]:
    """Fit a test's modes and return them as measured modes, bending planes merged.

    Parameters
    ----------
    test : FrfTest
        The test's FRFs, with a driving point (the accelerometer's position).
    known_mass_kg : float or None
        The bat's weighed mass, kg, for the fit's mass check (None: not weighed).

    Returns
    -------
    fit : ModalFit
        The modal fit (``ema.modal_fit.fit_test``).
    modes : MeasuredModes
        Its elastic modes at the points, in the test's point order, each resolved pair of
        bending planes merged (possibly none).
    """
    fit = fit_test(test, known_mass_kg=known_mass_kg)
    return fit, merge_plane_pairs(from_fit(fit, sensor_x_m(test)))
