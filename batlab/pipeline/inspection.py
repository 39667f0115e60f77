"""Files to verdict: a bat's inputs read once, then the method's one call.

    FRF file -> FrfTest -> fitted modes (``updating.correlate.fitted``), point rows in the
    baseline's order (``updating.correlate.points``)
    baseline modes + profile + meta -> calibrated reference (``updating.diagnose``)
    InspectionCase -> ``updating.inspect.run.inspect`` -> Verdict

The stateless form reads the bat's files (``inspect_files``); the registry form reads the
registered bat (``batlab.pipeline.registered``); both build an ``InspectionCase`` and call
``judge``. ``progress`` callables receive one-line messages.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from batlab.pipeline.chance import calibration_for, model_name, null_statistics, stated
from batlab.pipeline.files import (
    Progress,
    numeric_failure,
    quiet,
    read_bat_files,
    read_conditions,
    read_frf,
    read_retest_profile,
)
from batlab.pipeline.records import FittedTest
from ema.io.frf_data import FrfTest
from updating.correlate import fitted
from updating.correlate.points import match_points, point_positions_m, reorder
from updating.diagnose.calibrate_baseline import calibrate
from updating.diagnose.run import Diagnosis
from updating.inspect.retest_meta import RetestConditions, conditions_from_dict
from updating.inspect.run import inspect
from updating.inspect.verdict import Verdict
from updating.model.calipers import CaliperSurvey
from updating.model.lab_input import BatMeta
from updating.model.profile import Profile
from updating.model.reference import BatReference

__all__ = [
    "InspectionCase", "InspectionResult", "calibrate_baseline", "fit_file", "inspect_files",
    "judge", "stateless_case",
]


@dataclass(frozen=True)
class InspectionCase:
    """What the method judges: the bat, its reference and both fitted tests.

    Attributes
    ----------
    serial : str
        The bat's serial number.
    profile : Profile
        Its outer profile.
    reference : BatReference
        Its reference calibrated to the baseline.
    baseline, retest : FittedTest
        The two tests, the re-test's point rows in the baseline's order.
    registered : RetestConditions
        meta.json's weight (and the baseline's accelerometer mass and temperature).
    weight_kg : float or None
        The registered weight, kg.
    reference_seq : int or None
        The registration (custody record) a registered inspection is judged against.
    retest_content : bytes or None
        The re-test file's bytes as read (the registry keeps exactly the file judged).
    model : str or None
        The bat's model (``batlab.pipeline.chance.model_name``): whose calibration states
        its chance.
    survey : CaliperSurvey or None
        The re-test's caliper profile (retest_profile.csv), None without one.
    """

    serial: str
    profile: Profile
    reference: BatReference
    baseline: FittedTest
    retest: FittedTest
    registered: RetestConditions
    weight_kg: float | None
    reference_seq: int | None = None
    retest_content: bytes | None = None
    model: str | None = None
    survey: CaliperSurvey | None = None


@dataclass(frozen=True)
class InspectionResult:
    """Everything an inspection produced (the report draws from it).

    Attributes
    ----------
    serial, profile, reference, baseline, retest
        As in ``InspectionCase``.
    verdict : Verdict
        The verdict.
    reference_seq : int or None
        The registration a registered inspection was judged against.
    weight_kg : float or None
        The registered weight, kg.
    retest_content : bytes or None
        The re-test file's bytes as judged (stored as they are, even if the file on disk
        changes afterwards).
    conditions : RetestConditions or None
        The retest.json's conditions it was judged with (stored, so that a report can judge
        the stored tests again for the element map).
    model : str or None
        The bat's model.
    stated : dict or None
        The verdict's chance and false-alarm rate (``batlab.pipeline.chance.statement``,
        by ``chance.stated``); None: nominal, no calibration looked up.
    survey : CaliperSurvey or None
        The re-test's caliper profile it was judged with (stored likewise).
    """

    serial: str
    profile: Profile
    reference: BatReference
    baseline: FittedTest
    retest: FittedTest
    verdict: Verdict
    reference_seq: int | None = None
    weight_kg: float | None = None
    retest_content: bytes | None = None
    conditions: RetestConditions | None = None
    model: str | None = None
    stated: dict | None = None
    survey: CaliperSurvey | None = None


def fit_file(name: str, test: FrfTest, weight_kg: float | None,
             order: np.ndarray | None = None, progress: Progress = quiet) -> FittedTest:
    """Fit a test's modes (``updating.correlate.fitted.fit_measured``).

    Parameters
    ----------
    name : str
        The file's name (messages, errors).
    test : FrfTest
        Its FRFs.
    weight_kg : float or None
        The bat's weighed mass, kg.
    order : numpy.ndarray or None
        The baseline's point order (``match_points``), None to keep the test's.
    progress : Progress
        Receives one-line messages.

    Returns
    -------
    FittedTest
        The test with its fit and modes.

    Raises
    ------
    ValueError
        When the fit finds no elastic mode or fails on the numbers, naming the file.
    """
    progress(f"fitting modes of {name} ({test.frf.shape[2]} FRFs, {test.freq_hz.size} lines)")
    with numeric_failure(name):
        fit, modes = fitted.fit_measured(test, weight_kg)
    if modes.freq_hz.size == 0:
        raise ValueError(f"{name}: no elastic mode found in the test")
    if order is not None:
        modes = reorder(modes, order)
    progress(f"{name}: {modes.freq_hz.size} modes at "
             + ", ".join(f"{f:.1f}" for f in modes.freq_hz) + " Hz")
    return FittedTest(name, test, fit, modes)


def calibrate_baseline(profile: Profile, meta: BatMeta, baseline: FittedTest) -> Diagnosis:
    """Calibrate the bat's reference to its fitted baseline (``calibrate``).

    Parameters
    ----------
    profile : Profile
        The bat's outer profile.
    meta : BatMeta
        Its meta.json.
    baseline : FittedTest
        The baseline, fitted (its fit's suspension frequencies are used).

    Returns
    -------
    Diagnosis
        The diagnosis; ``.reference`` is the calibrated reference.
    """
    return calibrate(profile, meta, baseline.modes,
                     getattr(baseline.fit, "suspension_freq_hz", None))


def judge(case: InspectionCase, false_alarm: float,
          conditions: RetestConditions | None, with_map: bool = True,
          calibration=None) -> InspectionResult:
    """Judge a case: the method's one call (``updating.inspect.run.inspect``).

    Parameters
    ----------
    case : InspectionCase
        The bat, its reference and both fitted tests.
    false_alarm : float
        The decision's false-alarm rate.
    conditions : RetestConditions or None
        The re-test's retest.json.
    with_map : bool
        Compute the MSSO element map the report draws (False: the same verdict, sooner;
        a report of the stored verdict computes it then, ``stored.with_element_map``).
    calibration : StoredCalibration or None
        The calibration of the bat's model (``chance.calibration_for``): the decision reads
        the chance measured on its clean re-tests; None: the F distribution's. Not stated
        here (``chance.stated``).

    Returns
    -------
    InspectionResult
        The case with its verdict.
    """
    verdict = inspect(case.profile, case.reference, case.baseline.modes, case.retest.modes,
                      false_alarm, conditions, case.registered, with_map=with_map,
                      retest_profile=case.survey,
                      clean_F=None if calibration is None else null_statistics(calibration))
    return InspectionResult(case.serial, case.profile, case.reference, case.baseline,
                            case.retest, verdict, case.reference_seq, case.weight_kg,
                            case.retest_content, conditions, case.model,
                            survey=case.survey)


def stateless_case(profile_path, meta_path, baseline_path, retest_path,
                   progress: Progress = quiet, retest_profile_path=None) -> InspectionCase:
    """Read a bat's files, fit both tests and calibrate the reference to the baseline.

    Parameters
    ----------
    profile_path, meta_path, baseline_path, retest_path : str or os.PathLike
        profile.csv, meta.json and the two test files.
    progress : Progress
        Receives one-line messages.
    retest_profile_path : str or os.PathLike or None
        The optional retest_profile.csv (checked against profile.csv before any fit).

    Returns
    -------
    InspectionCase
        The case (no registration).
    """
    profile, meta = read_bat_files(profile_path, meta_path)
    survey = read_retest_profile(retest_profile_path, profile)
    base_test, re_test = read_frf(baseline_path), read_frf(retest_path)
    order = match_points(point_positions_m(base_test), point_positions_m(re_test),
                         str(retest_path))
    baseline = fit_file(Path(baseline_path).name, base_test, meta.weight_kg, progress=progress)
    progress("calibrating the reference model to the baseline (diagnose)")
    reference = calibrate_baseline(profile, meta, baseline).reference
    retest = fit_file(Path(retest_path).name, re_test, meta.weight_kg, order, progress)
    return InspectionCase(meta.serial, profile, reference, baseline, retest,
                          conditions_from_dict(meta.extra, meta_path), meta.weight_kg,
                          model=model_name(profile, meta.species, meta.extra),
                          survey=survey)


def inspect_files(
    profile_path, meta_path, baseline_path, retest_path, false_alarm: float = 0.01,
    progress: Progress = quiet, retest_meta_path=None, with_map: bool = True,
    retest_profile_path=None, conn=None, unmeasured_why: str | None = None,
) -> InspectionResult:
    """Inspect a re-test statelessly: the steps of `register`, then the re-test against it.

    Parameters
    ----------
    profile_path, meta_path, baseline_path, retest_path : str or os.PathLike
        profile.csv, meta.json and the two test files.
    false_alarm : float
        The decision's false-alarm rate.
    progress : Progress
        Receives one-line messages.
    retest_meta_path : str or os.PathLike or None
        The optional retest.json.
    with_map : bool
        Compute the MSSO element map (what a report draws; ``judge``).
    retest_profile_path : str or os.PathLike or None
        The optional retest_profile.csv (the re-test's caliper profile).
    conn : sa.Connection or None
        A registry to read the bat model's calibration from (else batlab's shipped one).
    unmeasured_why : str or None
        Why no registry was read, in words.

    Returns
    -------
    InspectionResult
        The verdict and what it was judged on, decided on and stated with the bat model's
        calibration (``chance.calibration_for``), or the nominal chance without one.
    """
    conditions = read_conditions(retest_meta_path)
    case = stateless_case(profile_path, meta_path, baseline_path, retest_path, progress,
                          retest_profile_path)
    calibration, why = calibration_for(conn, case.model, unmeasured_why)
    progress("inspecting the re-test against the reference")
    return stated(judge(case, false_alarm, conditions, with_map, calibration), calibration,
                  why)
