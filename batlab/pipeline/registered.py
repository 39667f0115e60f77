"""A registered bat: register it, inspect a re-test against it, store the verdict.

The registry's storage (SQL, hashes, custody records) stays behind ``batlab.registry``'s
API; the method's steps are those of ``batlab.pipeline.inspection``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import sqlalchemy as sa

from batlab import registry as reg
from batlab.pipeline.chance import calibration_for, model_name, stated
from batlab.pipeline.files import (
    Progress,
    frf_from_bytes,
    quiet,
    read_bat_files,
    read_conditions,
    read_frf,
    read_retest_profile,
    same_test_reason,
)
from batlab.pipeline.inspection import (
    InspectionCase,
    InspectionResult,
    calibrate_baseline,
    fit_file,
    judge,
)
from batlab.pipeline.records import FORCED_KEY, FittedTest
from batlab.version import code_version
from updating.correlate.measured import driving_mass_line
from updating.correlate.points import match_points, point_positions_m
from updating.inspect.retest_meta import RetestConditions, conditions_from_dict, stations_problem
from updating.model import plausible
from updating.model.lab_input import BatMeta
from updating.model.profile import Profile, make_profile
from updating.model.reference import BatReference
from updating.model.units import LB_TO_KG, PSI_TO_PA

__all__ = [
    "Registration", "inspect_registered", "prepare_registration", "register_files",
    "registered_case", "require_unregistered", "store_registration",
]


@dataclass(frozen=True)
class Registration:
    """A registered bat: its registry record, fitted baseline and diagnosis.

    Attributes
    ----------
    record : BatRecord
        The registry's record of the bat.
    baseline : FittedTest
        The baseline, fitted.
    diagnosis : Diagnosis
        The baseline's diagnosis (its calibrated reference).
    """

    record: reg.BatRecord
    baseline: FittedTest
    diagnosis: object


def registered_weight_kg(bat: reg.BatRecord) -> float | None:
    """Return a registered bat's weight from its meta.json, kg (None when not weighed)."""
    weight = bat.meta.get("weight_lb")
    return None if weight is None else float(weight) * LB_TO_KG


def registration_conditions(meta: dict, serial: str) -> RetestConditions:
    """Return the conditions a registered bat's meta.json recorded at its baseline.

    ``conditions_from_dict`` of the stored meta.json, errors naming the registered bat.
    """
    return conditions_from_dict(meta, f"registered bat {serial}")


def baseline_mass_line(profile: Profile, meta: BatMeta, baseline: FittedTest) -> str | None:
    """Check the baseline's driving-point mass line against the profile and scale weight.

    ``updating.model.plausible.check_mass_line``; None when it is plausible, or the bat was
    not weighed, or the test has no driving point or mass line.
    """
    row = driving_mass_line(baseline.fit)
    if row is None or meta.weight_kg is None:
        return None
    d = baseline.fit.driving_index
    return plausible.check_mass_line(float(row[d]), profile.x_m, profile.diameter_m,
                                     meta.weight_kg, float(baseline.fit.x_m[d]))


def prepare_registration(
    profile_path, meta_path, baseline_path, serial: str | None = None,
    progress: Progress = quiet, force: bool = False,
) -> Registration:
    """Read a new bat's files, fit its baseline and calibrate its reference (nothing stored).

    A baseline that ``plausible.check_baseline`` finds odd is refused unless ``force``; then
    its message is kept in the record's meta as ``FORCED_KEY``, which every report shows.

    Parameters
    ----------
    profile_path, meta_path, baseline_path : str or os.PathLike
        profile.csv, meta.json and the baseline test file.
    serial : str or None
        The serial the lab gave (must be meta.json's).
    progress : Progress
        Receives one-line messages.
    force : bool
        Register an odd baseline anyway (the record says so).

    Returns
    -------
    Registration
        The record to store, the fitted baseline and its diagnosis.
    """
    profile, meta = read_bat_files(profile_path, meta_path)
    if serial is not None and serial != meta.serial:
        raise ValueError(f"{meta_path}: serial {meta.serial!r} differs from --serial {serial!r}")
    test = read_frf(baseline_path)
    baseline = fit_file(Path(baseline_path).name, test, meta.weight_kg, progress=progress)
    progress("calibrating the reference model to the baseline (diagnose)")
    diagnosis = calibrate_baseline(profile, meta, baseline)
    slip = plausible.check_baseline(diagnosis.reference.E_pa / PSI_TO_PA, meta.species,
                                    diagnosis.extended.rms_pct, diagnosis.warnings,
                                    str(baseline_path), meta.serial,
                                    baseline_mass_line(profile, meta, baseline))
    if slip and not force:
        raise ValueError(slip)
    stored_meta = dict(meta.extra)
    if slip:
        progress(f"registered with --force although: {slip}")
        stored_meta[FORCED_KEY] = slip
    record = reg.BatRecord(
        serial=meta.serial, profile_x_m=profile.x_m.tolist(),
        profile_diameter_m=profile.diameter_m.tolist(), meta=stored_meta, species=meta.species,
        reference=diagnosis.reference.to_dict(), modes=reg.encode_modes(baseline.modes),
        code=code_version())
    return Registration(record, baseline, diagnosis)


def require_unregistered(conn: sa.Connection, serial: str) -> None:
    """Raise ValueError when ``serial`` is already registered (a new bat needs --replace)."""
    if reg.has_bat(conn, serial):
        raise ValueError(f"bat {serial!r} is already registered (use --replace)")


def register_files(
    conn: sa.Connection, profile_path, meta_path, baseline_path,
    serial: str | None = None, replace: bool = False, progress: Progress = quiet,
) -> Registration:
    """Register a bat: fit, calibrate, store with a copy of the baseline file.

    Parameters
    ----------
    conn : sa.Connection
        The registry.
    profile_path, meta_path, baseline_path : str or os.PathLike
        profile.csv, meta.json and the baseline test file.
    serial : str or None
        The serial the lab gave (must be meta.json's).
    replace : bool
        Replace a registered bat of that serial.
    progress : Progress
        Receives one-line messages.

    Returns
    -------
    Registration
        The stored record, the fitted baseline and its diagnosis.
    """
    if not replace:  # fail fast, before the fit (add_bat checks again, under the lock)
        require_unregistered(conn, read_bat_files(profile_path, meta_path)[1].serial)
    done = prepare_registration(profile_path, meta_path, baseline_path, serial, progress)
    return store_registration(conn, done, baseline_path, replace, progress)


def store_registration(conn: sa.Connection, done: Registration, baseline_path,
                       replace: bool = False, progress: Progress = quiet) -> Registration:
    """Store a prepared registration with a copy of its baseline file.

    Parameters
    ----------
    conn : sa.Connection
        The registry.
    done : Registration
        ``prepare_registration``'s result.
    baseline_path : str or os.PathLike
        The baseline test file.
    replace : bool
        Replace a registered bat of that serial.
    progress : Progress
        Receives one-line messages.

    Returns
    -------
    Registration
        The stored record, the fitted baseline and its diagnosis.
    """
    content = Path(baseline_path).read_bytes()
    stored = reg.add_bat(conn, done.record, Path(baseline_path).name, content, replace=replace)
    progress(f"registered {stored.serial} (baseline sha256 {stored.baseline_sha256[:12]})")
    return Registration(stored, done.baseline, done.diagnosis)


def registration_case(
    bat: reg.BatRecord, serial: str, baseline: tuple[str, bytes], retest: tuple[str, bytes],
    retest_label: str | None = None, refit_baseline: bool = False,
    progress: Progress = quiet, baseline_fit=None, retest_profile_path=None,
    fresh: bool = True,
) -> InspectionCase:
    """Read a registration and the bytes of its two tests into the method's inputs.

    The one reading of a registered bat and a re-test (``registered_case``: a re-test file
    against the bat's current registration; ``stored.stored_case``: a stored inspection
    against the registration it was judged with): both tests read from their bytes, the
    re-test's points put in the baseline's order, the profile, the registered weight and
    conditions, the baseline's registered modes (its file refitted only for a report's
    figures), the re-test fitted.

    Parameters
    ----------
    bat : BatRecord
        The registration.
    serial : str
        The bat's serial number.
    baseline, retest : (str, bytes)
        Each test file's name (its extension gives the format) and bytes.
    retest_label : str or None
        What errors call the re-test (default its name).
    refit_baseline : bool
        Refit the baseline file (for a report's figures).
    progress : Progress
        Receives one-line messages.
    baseline_fit : ModalFit or None
        A fit of that same baseline file already at hand (saves the refit).
    retest_profile_path : path or None
        The re-test's caliper profile (retest_profile.csv), read before any fit.
    fresh : bool
        A re-test to judge now: refused (ValueError naming both files) when it is the
        baseline over again (``files.same_test_reason``). False for a stored inspection read
        back (it is evidence as it was judged).

    Returns
    -------
    InspectionCase
        The case, with the registration it is judged against and the re-test's bytes.
    """
    (base_name, base_bytes), (re_name, re_bytes) = baseline, retest
    base_test = frf_from_bytes(base_bytes, base_name)
    re_test = frf_from_bytes(re_bytes, re_name, retest_label)
    if fresh:
        why = same_test_reason(f"{base_name} (bat {serial}'s registered baseline)", base_test,
                               base_bytes, retest_label or re_name, re_test, re_bytes)
        if why:
            raise ValueError(why)
    base_modes = reg.decode_modes(bat.modes)
    order = match_points(base_modes.x_m, point_positions_m(re_test), retest_label or re_name)
    profile = make_profile(bat.profile_x_m, bat.profile_diameter_m, f"registry bat {serial}")
    survey = read_retest_profile(retest_profile_path, profile)
    weight_kg = registered_weight_kg(bat)
    fit = baseline_fit
    if refit_baseline and fit is None:
        fit = fit_file(base_name, base_test, weight_kg, None, progress).fit
    fitted = FittedTest(base_name, base_test, fit, base_modes)
    re_fit = fit_file(re_name, re_test, weight_kg, order, progress)
    return InspectionCase(serial, profile, BatReference.from_dict(bat.reference), fitted,
                          re_fit, registration_conditions(bat.meta, serial), weight_kg,
                          bat.reference_seq, re_bytes,
                          model_name(profile, bat.species, bat.meta), survey)


def registered_case(
    conn: sa.Connection, serial: str, retest_path, refit_baseline: bool = False,
    progress: Progress = quiet, baseline_fit=None, retest_profile_path=None,
) -> InspectionCase:
    """Read a registered bat and a re-test file into the method's inputs.

    The stored baseline file is read (its checksum checked) to check the re-test's points
    and, with ``refit_baseline`` (for a report), to show its FRFs and stabilisation diagram;
    the baseline's modes and the reference are the registered ones (``registration_case``).

    Parameters
    ----------
    conn : sa.Connection
        The registry.
    serial : str
        The bat's serial number.
    retest_path : str or os.PathLike
        The re-test file.
    refit_baseline : bool
        Refit the stored baseline file (for a report's figures).
    progress : Progress
        Receives one-line messages.
    baseline_fit : ModalFit or None
        A fit of that same baseline file already at hand (saves the refit).
    retest_profile_path : str or os.PathLike or None
        The optional retest_profile.csv (checked against the registered profile before any
        fit).

    Returns
    -------
    InspectionCase
        The case, with the registration it is judged against and the re-test's bytes.
    """
    bat = reg.get_bat(conn, serial)
    baseline = (bat.baseline_name, reg.baseline_file(conn, bat))
    if not Path(retest_path).is_file():
        raise ValueError(f"{retest_path}: no such file")
    retest = (Path(retest_path).name, Path(retest_path).read_bytes())
    return registration_case(bat, serial, baseline, retest, str(retest_path), refit_baseline,
                             progress, baseline_fit, retest_profile_path)


def inspect_registered(
    conn: sa.Connection, serial: str, retest_path, false_alarm: float = 0.01,
    refit_baseline: bool = False, progress: Progress = quiet, baseline_fit=None,
    retest_meta_path=None, with_map: bool = True, retest_profile_path=None,
) -> InspectionResult:
    """Inspect a re-test of a registered bat against its stored reference and baseline modes.

    Parameters
    ----------
    conn : sa.Connection
        The registry.
    serial : str
        The bat's serial number.
    retest_path : str or os.PathLike
        The re-test file.
    false_alarm : float
        The decision's false-alarm rate.
    refit_baseline : bool
        Refit the stored baseline file (for a report's figures).
    progress : Progress
        Receives one-line messages.
    baseline_fit : ModalFit or None
        A fit of that same baseline file already at hand (saves the refit).
    retest_meta_path : str or os.PathLike or None
        The optional retest.json.
    with_map : bool
        Compute the MSSO element map (what a report draws; without it a later report
        computes it, ``stored.with_element_map``).
    retest_profile_path : str or os.PathLike or None
        The optional retest_profile.csv (the re-test's caliper profile).

    Returns
    -------
    InspectionResult
        The verdict and what it was judged on, decided on and stated with the registry's
        latest calibration of the bat's model (``chance.calibration_for``; nothing stored:
        ``store_inspection``).
    """
    conditions = read_conditions(retest_meta_path)
    bat = reg.get_bat(conn, serial)
    why = stations_problem(conditions, float(bat.profile_x_m[-1] - bat.profile_x_m[0]))
    if why:
        raise ValueError(f"{retest_meta_path}: {why}")
    case = registered_case(conn, serial, retest_path, refit_baseline, progress, baseline_fit,
                           retest_profile_path)
    calibration, why = calibration_for(conn, case.model)
    progress("inspecting the re-test against the registered reference")
    return stated(judge(case, false_alarm, conditions, with_map, calibration), calibration,
                  why)
