"""The reference model of a bat calibrated to its baseline test (the registration's step)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from updating.correlate.measured import MeasuredModes
from updating.diagnose.run import Diagnosis, diagnose
from updating.model.lab_input import BatMeta
from updating.model.profile import Profile


def calibrate(profile: Profile, meta: BatMeta, baseline_modes: MeasuredModes,
              suspension_hz: Sequence[float] | np.ndarray | None = None) -> Diagnosis:
    """Diagnose a baseline test with the default settings; its ``reference`` is calibrated.

    Parameters
    ----------
    profile : Profile
        The bat's outer profile.
    meta : BatMeta
        The bat's meta.json (handbook wood, weight).
    baseline_modes : MeasuredModes
        The baseline's elastic modes at the test points.
    suspension_hz : array_like or None
        The rigid-body (suspension) frequencies the fit found below 20 Hz, Hz; None or
        empty when it found none.

    Returns
    -------
    Diagnosis
        The diagnosis (``updating.diagnose.run.diagnose``); ``.reference`` is the bat's
        calibrated reference model.
    """
    susp = None if suspension_hz is None or len(suspension_hz) == 0 else \
        np.asarray(suspension_hz)
    return diagnose(profile, meta, baseline_modes, suspension_hz=susp)
