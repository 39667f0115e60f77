"""Diagnose a baseline, check a rig.

A baseline against the nominal model (`batlab diagnose`), a rig's reference bar
(`batlab check-rig`): a test file fitted, then the diagnosis.
"""

from __future__ import annotations

import numpy as np

from batlab.pipeline.files import Progress, numeric_failure, quiet, read_bat_files, read_frf
from updating.correlate.measured import from_fit
from updating.correlate.points import sensor_x_m

__all__ = [
    "check_rig_files", "diagnose_files",
]


def fit_frf_file(frf_path, method: str, progress: Progress = quiet):
    """Fit a test file's modes by ``ema.modal_fit.fit_test`` with ``method``.

    Parameters
    ----------
    frf_path : str or os.PathLike
        The test file.
    method : str
        The pole estimator.
    progress : Progress
        Receives one-line messages.

    Returns
    -------
    fit : ModalFit
        The fit.
    measured : MeasuredModes
        Its elastic modes (bending planes not merged).

    Raises
    ------
    ValueError
        When the fit finds no elastic mode, naming the file.
    """
    from ema.modal_fit import fit_test

    test = read_frf(frf_path)
    progress(f"fitting the modes of {frf_path} ...")
    with numeric_failure(str(frf_path)):
        fit = fit_test(test, method=method)
    measured = from_fit(fit, sensor_x_m(test))
    if measured.freq_hz.size == 0:
        raise ValueError(f"{frf_path}: the fitter found no elastic mode above 20 Hz")
    return fit, measured


def diagnose_files(
    profile_path, meta_path, frf_path, method: str = "lscf", min_gain_pct: float | None = None,
    progress: Progress = quiet, solid: bool = False,
):
    """Run `batlab diagnose`: a baseline test file against the nominal model.

    Its modes fitted by ``ema.modal_fit.fit_test`` with ``method``, then
    ``updating.diagnose.run.diagnose``; with ``solid``, a second pass tries the 3D solid's
    per-mode corrections (``updating.diagnose.solid.diagnose_with_solid``, about a minute).

    Parameters
    ----------
    profile_path, meta_path, frf_path : str or os.PathLike
        profile.csv, meta.json and the baseline test file.
    method : str
        The pole estimator.
    min_gain_pct : float or None
        The least gain, percentage points, of a named cause (None: the default).
    progress : Progress
        Receives one-line messages.
    solid : bool
        Also try the 3D solid's corrections.

    Returns
    -------
    meta : BatMeta
        The bat's meta.json.
    diagnosis : Diagnosis
        The diagnosis.
    """
    from updating.diagnose.run import MIN_GAIN_PCT, diagnose

    profile, meta = read_bat_files(profile_path, meta_path)
    fit, measured = fit_frf_file(frf_path, method, progress)
    progress(f"{measured.freq_hz.size} elastic modes; ranking the causes ...")
    susp = getattr(fit, "suspension_freq_hz", None)
    gain = MIN_GAIN_PCT if min_gain_pct is None else min_gain_pct
    if not solid:
        return meta, diagnose(profile, meta, measured, susp, min_gain_pct=gain)
    from updating.diagnose.solid import diagnose_with_solid

    result, corr = diagnose_with_solid(profile, meta, measured, susp, progress=True,
                                       min_gain_pct=gain)
    progress("3D/1D corrections per plane, %: "
             + "; ".join(" ".join(f"{100 * c:+.2f}" for c in row) for row in corr))
    return meta, result


def check_rig_files(
    bar_path, frf_path, method: str = "lscf", freq_tol: float | None = None,
    max_damping: float | None = None, scale_tol: float | None = None,
    progress: Progress = quiet,
):
    """Run `batlab check-rig`: a reference bar's test against the bar's model.

    ``updating.diagnose.rig_check.check_rig``; tolerances as fractions, None for the
    defaults.

    Parameters
    ----------
    bar_path, frf_path : str or os.PathLike
        The bar's JSON and its test file.
    method : str
        The pole estimator.
    freq_tol, max_damping, scale_tol : float or None
        The check's tolerances (None: the defaults).
    progress : Progress
        Receives one-line messages.

    Returns
    -------
    RigCheck
        The check's result.
    """
    from updating.diagnose.rig_check import FREQ_TOL, MAX_DAMPING, SCALE_TOL, check_rig
    from updating.model.bar import read_bar_json

    bar = read_bar_json(bar_path)
    fit, measured = fit_frf_file(frf_path, method, progress)
    ml = getattr(fit, "mass_line", None)
    ml_dp = None
    if ml is not None and np.size(ml) and fit.driving_frf is not None:
        ml_dp = float(np.real(np.asarray(ml)[fit.driving_frf]))
    return check_rig(
        bar, measured, ml_dp if ml_dp and ml_dp > 0 else None,
        freq_tol=FREQ_TOL if freq_tol is None else freq_tol,
        max_damping=MAX_DAMPING if max_damping is None else max_damping,
        scale_tol=SCALE_TOL if scale_tol is None else scale_tol)
