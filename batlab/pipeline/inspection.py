"""Files to verdict: the operations behind `register`, `inspect`, `report`, `export`,
`diagnose`, `check-rig`, `fit` and `demo`. The registry's storage (SQL, hashes, custody
records) stays behind ``batlab.registry``'s API.

    FRF file -> FrfTest -> modal fit -> MeasuredModes (sensor at the driving point)
    baseline modes + profile + meta -> diagnose -> calibrated BatReference
    reference + baseline modes + re-test modes -> inspect_retest -> Verdict -> contract JSON

Positions are SI inside; the contract dict (docs/contract.md) is in inches from the knob
end. ``progress`` callables receive one-line messages (the commands print them on stderr).
"""

from __future__ import annotations

import math
import os
import sqlite3
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from batlab import __version__
from batlab import registry as reg
from ema.io.atomic_write import atomic_write
from ema.io.frf_data import FrfTest
from ema.modal_fit import MIN_SNR
from updating.correlate.measured import MeasuredModes, from_fit
from updating.inspect.planes import merge_plane_pairs
from updating.inspect.retest_meta import (
    RetestConditions,
    conditions_from_dict,
    read_retest_meta,
)
from updating.inspect.verdict import Verdict
from updating.model.lab_input import BatMeta, read_meta
from updating.model.profile import Profile, make_profile, read_profile_csv
from updating.model.reference import BatReference
from updating.model.units import IN_TO_M, LB_TO_KG

POINT_TOL_M = 0.25 * IN_TO_M
"""A re-test impact point may sit this far from the baseline's (marks on the bat)."""

Progress = Callable[[str], None]


def _quiet(_: str) -> None:
    return None


@dataclass(frozen=True)
class FittedTest:
    """One test file, read and fitted.

    Attributes:
        name: the file's name (for messages and the report).
        test: the FRFs.
        fit: the modal fit (``ema.modal_fit.ModalFit``), or None for a registered baseline whose
            modes come from the registry.
        modes: elastic modes at the impact points, in the baseline's point order.
    """

    name: str
    test: FrfTest
    fit: object | None
    modes: MeasuredModes


@dataclass(frozen=True)
class InspectionResult:
    """Everything an inspection produced (the report draws from it)."""

    serial: str
    profile: Profile
    reference: BatReference
    baseline: FittedTest
    retest: FittedTest
    verdict: Verdict
    reference_seq: int | None = None
    """The registration (custody record) a registered inspection was judged against."""
    weight_kg: float | None = None
    retest_content: bytes | None = None
    """The re-test file's bytes as judged (stored as they are: the registry keeps exactly the
    file that was read, even if the file on disk changes afterwards)."""


@dataclass(frozen=True)
class ReportInputs:
    """What a report is drawn from: the verdict as stored (``verdict_record``: the contract
    JSON with the verdict's evidence), the model and both fitted tests, the bat's meta.json
    and the provenance (file hashes, custody record hashes, inspection number and time).
    Stored inspections rebuild it from the registry alone (``stored_report_inputs``)."""

    serial: str
    profile: Profile
    reference: BatReference
    baseline: FittedTest
    retest: FittedTest
    verdict: dict
    meta: dict
    provenance: dict


# --- files -----------------------------------------------------------------------------------


def read_frf(path: str | os.PathLike) -> FrfTest:
    """Read an FRF test file (UFF, CSV, NPZ) with a driving point; one-line errors naming it."""
    from ema.io.frf_io import read_test

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    try:
        return read_test(path)
    except (ValueError, OSError):
        raise
    except Exception as exc:  # a reader's internal error on a damaged file
        raise ValueError(f"{path}: unreadable FRF file ({type(exc).__name__}: {exc})") from None


def frf_from_bytes(content: bytes, name: str, label: str | None = None) -> FrfTest:
    """Read an FRF file's bytes (its format from ``name``'s extension); errors name ``label``
    (default ``name``), not the temporary copy."""
    with tempfile.TemporaryDirectory(prefix="batlab-") as tmp:
        path = Path(tmp) / Path(name).name
        path.write_bytes(content)
        try:
            return read_frf(path)
        except ValueError as exc:
            raise ValueError(str(exc).replace(str(path), label or name)) from None


def read_bat_files(profile_path, meta_path) -> tuple[Profile, BatMeta]:
    """profile.csv and meta.json; a missing file is a one-line error naming it."""
    for p in (profile_path, meta_path):
        if not Path(p).is_file():
            raise ValueError(f"{p}: no such file")
    profile = read_profile_csv(profile_path)
    meta = read_meta(meta_path)
    if meta.points_m.size and meta.points_m.max() > profile.length_m + POINT_TOL_M:
        raise ValueError(f"{meta_path}: points_in run past the end of the bat "
                         f"({profile.length_m / IN_TO_M:.2f} in long in {profile_path})")
    return profile, meta


def read_conditions(path) -> RetestConditions | None:
    """retest.json (optional): the re-test's weight, accelerometer mass, temperature, date."""
    return None if path is None else read_retest_meta(path)


# --- modes -----------------------------------------------------------------------------------


def point_positions_m(test: FrfTest) -> np.ndarray:
    """Positions of the nodes the mode shapes are given at: the roving side of the test (the
    impact nodes for a roving hammer, the accelerometers for a roving accelerometer)."""
    nodes = test.reference_nodes if test.frf.shape[2] >= test.frf.shape[1] else \
        test.response_nodes
    return test.x_m(nodes)


def match_points(baseline_x_m: np.ndarray, retest_x_m: np.ndarray, retest_name: str) -> np.ndarray:
    """Index into the re-test's points for each baseline point; ValueError when the re-test's
    points are not the baseline's (count, or a point further than POINT_TOL_M from any)."""
    base = np.asarray(baseline_x_m, dtype=float)
    new = np.asarray(retest_x_m, dtype=float)
    if base.size != new.size:
        raise ValueError(f"{retest_name}: {new.size} test points, the baseline has {base.size}")
    order = np.argmin(np.abs(base[:, None] - new[None, :]), axis=1)
    miss = np.abs(new[order] - base)
    if np.unique(order).size != base.size or miss.max() > POINT_TOL_M:
        k = int(np.argmax(miss))
        raise ValueError(f"{retest_name}: test points do not match the baseline's (baseline "
                         f"point at {base[k] / IN_TO_M:.2f} in has no re-test point within "
                         f"{POINT_TOL_M / IN_TO_M:.2f} in)")
    return order


def fit_modes(test: FrfTest, known_mass_kg: float | None = None):
    """The automatic modal fit of a test (``ema.modal_fit.fit_test``, polyreference LSCF)."""
    from ema.modal_fit import fit_test

    return fit_test(test, known_mass_kg=known_mass_kg)


def sensor_x_m(test: FrfTest) -> float:
    """Position of the accelerometer: the driving point's node."""
    i, _ = test.driving_point
    return float(test.node_x_m[int(test.response_nodes[i])])


def reorder(modes: MeasuredModes, order: np.ndarray) -> MeasuredModes:
    """The modes with their point rows taken in ``order``."""
    return MeasuredModes(modes.freq_hz, modes.shapes[order], modes.x_m[order],
                         modes.damping_ratio, modes.sensor_x_m, modes.freq_std_hz)


def fit_file(
    name: str, test: FrfTest, weight_kg: float | None, order: np.ndarray | None = None,
    progress: Progress = _quiet,
) -> FittedTest:
    """Fit a test; its modes' point rows optionally re-ordered to the baseline's points."""
    progress(f"fitting modes of {name} ({test.frf.shape[2]} FRFs, {test.freq_hz.size} lines)")
    fit = fit_modes(test, weight_kg)
    modes = merge_plane_pairs(from_fit(fit, sensor_x_m(test)))
    if modes.freq_hz.size == 0:
        raise ValueError(f"{name}: no elastic mode found in the test")
    if order is not None:
        modes = reorder(modes, order)
    progress(f"{name}: {modes.freq_hz.size} modes at "
             + ", ".join(f"{f:.1f}" for f in modes.freq_hz) + " Hz")
    return FittedTest(name, test, fit, modes)


def read_test_file(path, require_driving: bool = True) -> FrfTest:
    """An FRF test file as ``ema.io.frf_io.read_test`` reads it (`batlab fit`: a test without
    a driving point is allowed with ``require_driving`` False)."""
    from ema.io.frf_io import read_test

    return read_test(path, require_driving=require_driving)


def fit_test_file(test: FrfTest, band_hz=None, method: str = "lscf", max_order=None,
                  known_mass_kg: float | None = None, refine: bool = False,
                  min_snr: float = MIN_SNR):
    """`batlab fit`: the automatic modal analysis of a test (``ema.modal_fit.fit_test``)."""
    from ema.modal_fit import fit_test

    return fit_test(test, band_hz=band_hz, method=method, max_order=max_order,
                    known_mass_kg=known_mass_kg, refine=refine, min_snr=min_snr)


def write_modes_file(path, fit) -> None:
    """A fit's real mass-normalised modes as UFF 55 (``ema.io.uff_modes``)."""
    from ema.io.uff_modes import write_modes_uff

    write_modes_uff(path, fit.freq_hz, fit.damping_ratio, fit.real_shapes, fit.nodes, fit.x_m)


def plot_fit_files(fit, test: FrfTest, out_dir) -> list:
    """stabilisation.png, synthesis.png and automac.png of a fit in ``out_dir``
    (``ema.plots.plot_fit``, the FRFs of the fitted band); the paths written."""
    from ema.plots import plot_fit

    sel = (test.freq_hz >= fit.band_hz[0]) & (test.freq_hz <= fit.band_hz[1])
    sel &= test.freq_hz > 0
    return list(plot_fit(fit, test.frf[sel], out_dir))


# --- the updating stage ----------------------------------------------------------------------


def calibrate(profile: Profile, meta: BatMeta, baseline: FittedTest):
    """Diagnose the baseline: the calibrated reference (``updating.diagnose.run``)."""
    from updating.diagnose.run import diagnose

    susp = getattr(baseline.fit, "suspension_freq_hz", None)
    susp = None if susp is None or len(susp) == 0 else np.asarray(susp)
    return diagnose(profile, meta, baseline.modes, suspension_hz=susp)


def fit_frf_file(frf_path, method: str, progress: Progress = _quiet):
    """(ModalFit, MeasuredModes) of a test file by ``ema.modal_fit.fit_test`` with ``method``; a
    test with no elastic mode is an error naming the file."""
    from ema.modal_fit import fit_test

    test = read_frf(frf_path)
    progress(f"fitting the modes of {frf_path} ...")
    fit = fit_test(test, method=method)
    measured = from_fit(fit, sensor_x_m(test))
    if measured.freq_hz.size == 0:
        raise ValueError(f"{frf_path}: the fitter found no elastic mode above 20 Hz")
    return fit, measured


def diagnose_files(
    profile_path, meta_path, frf_path, method: str = "lscf", min_gain_pct: float | None = None,
    progress: Progress = _quiet, solid: bool = False,
):
    """`batlab diagnose`: (meta, Diagnosis) of a baseline test file against the nominal model
    (``updating.diagnose.run.diagnose``), its modes fitted by ``ema.modal_fit.fit_test`` with
    ``method``; with ``solid``, a second pass tries the 3D solid's per-mode corrections
    (``updating.diagnose.solid.diagnose_with_solid``, about a minute)."""
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
    progress: Progress = _quiet,
):
    """`batlab check-rig`: a reference bar's test against the bar's model
    (``updating.diagnose.rig_check.check_rig``); tolerances as fractions, None for the
    defaults."""
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


def inspect_modes(
    profile: Profile, reference: BatReference, baseline: MeasuredModes, retest: MeasuredModes,
    false_alarm: float, conditions: RetestConditions | None = None,
    registered: RetestConditions | None = None,
) -> Verdict:
    """Phase 3: the verdict on a re-test against the reference (``updating.inspect.run``);
    ``conditions``: retest.json, ``registered``: the same keys of meta.json (weight_lb, and
    accelerometer_mass_g, temperature_c of the baseline when the lab recorded them)."""
    from updating.inspect.run import inspect_retest

    reg_ = registered or RetestConditions()
    return inspect_retest(profile, reference, baseline, retest, false_alarm=false_alarm,
                          conditions=conditions, registered_weight_kg=reg_.weight_kg,
                          baseline_temperature_c=reg_.temperature_c,
                          baseline_sensor_mass_kg=reg_.sensor_mass_kg)


# --- JSON ------------------------------------------------------------------------------------


def _in(x_m: float) -> float:
    return round(float(x_m) / IN_TO_M, 4)


def _num(v) -> float | None:
    return None if v is None or not math.isfinite(float(v)) else float(v)


def contract_dict(serial: str, verdict: Verdict) -> dict:
    """The verdict as docs/contract.md fixes it (status, altered true/false/null, reasons;
    inches from the knob end; region, core and fill null unless altered), plus the decision's
    confidence and significance level."""
    altered = verdict.altered is True
    region = verdict.region_m if altered else None
    core = verdict.core_diameter_m if altered else None
    fill = verdict.fill_density_ratio if altered else None
    elements = [
        {"x0_in": _in(a), "x1_in": _in(b), "alpha": float(al), "beta": float(be)}
        for a, b, al, be in zip(verdict.element_x0_m, verdict.element_x1_m, verdict.alpha,
                                verdict.beta, strict=True)
    ]
    return {
        "serial": serial,
        "status": verdict.status.value,
        "altered": verdict.altered if verdict.altered is None else bool(verdict.altered),
        "reasons": [str(r) for r in verdict.reasons],
        "region_in": None if region is None else [_in(region[0]), _in(region[1])],
        "core_diameter_in": None if core is None else round(float(core) / IN_TO_M, 4),
        "fill_density_ratio": _num(fill),
        "elements": elements,
        "confidence": _num(verdict.confidence),
        "false_alarm_rate": _num(verdict.false_alarm_rate),
    }


def jsonable(value):
    """numpy scalars/arrays, tuples and dataclass-free containers -> JSON types (NaN -> None)."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return _num(value)
    if value is None or isinstance(value, str):
        return value
    return str(value)


def verdict_record(serial: str, verdict: Verdict) -> dict:
    """What the registry keeps of an inspection: the contract dict and the verdict's details."""
    out = contract_dict(serial, verdict)
    details = {} if verdict.details is None else verdict.details.to_json_dict()
    out.update(jsonable({"statistic": verdict.statistic, "moisture": verdict.moisture,
                         "uncertainty": verdict.uncertainty,
                         "modes": [m.to_json_dict() for m in verdict.modes],
                         "details": details}))
    return out


# --- whole operations ------------------------------------------------------------------------


@dataclass(frozen=True)
class Registration:
    record: reg.BatRecord
    baseline: FittedTest
    diagnosis: object


def prepare_registration(
    profile_path, meta_path, baseline_path, serial: str | None = None,
    progress: Progress = _quiet,
) -> Registration:
    """Read a new bat's files, fit its baseline and calibrate its reference (nothing stored)."""
    profile, meta = read_bat_files(profile_path, meta_path)
    if serial is not None and serial != meta.serial:
        raise ValueError(f"{meta_path}: serial {meta.serial!r} differs from --serial {serial!r}")
    test = read_frf(baseline_path)
    baseline = fit_file(Path(baseline_path).name, test, meta.weight_kg, progress=progress)
    progress("calibrating the reference model to the baseline (diagnose)")
    diagnosis = calibrate(profile, meta, baseline)
    record = reg.BatRecord(
        serial=meta.serial, profile_x_m=profile.x_m.tolist(),
        profile_diameter_m=profile.diameter_m.tolist(), meta=meta.extra, species=meta.species,
        reference=diagnosis.reference.to_dict(), modes=reg.encode_modes(baseline.modes))
    return Registration(record, baseline, diagnosis)


def register_files(
    conn: sqlite3.Connection, profile_path, meta_path, baseline_path,
    serial: str | None = None, replace: bool = False, progress: Progress = _quiet,
) -> Registration:
    """Register a bat: fit, calibrate, store with a copy of the baseline file."""
    if not replace:  # fail fast, before the fit (add_bat checks again, under the lock)
        _, meta = read_bat_files(profile_path, meta_path)
        if reg.has_bat(conn, meta.serial):
            raise ValueError(f"bat {meta.serial!r} is already registered (use --replace)")
    done = prepare_registration(profile_path, meta_path, baseline_path, serial, progress)
    content = Path(baseline_path).read_bytes()
    stored = reg.add_bat(conn, done.record, Path(baseline_path).name, content, replace=replace)
    progress(f"registered {stored.serial} (baseline sha256 {stored.baseline_sha256[:12]})")
    return Registration(stored, done.baseline, done.diagnosis)


def inspect_files(
    profile_path, meta_path, baseline_path, retest_path, false_alarm: float = 0.01,
    progress: Progress = _quiet, retest_meta_path=None,
) -> InspectionResult:
    """The stateless inspection: the same steps as register, then the re-test against it
    (``retest_meta_path``: the optional retest.json)."""
    profile, meta = read_bat_files(profile_path, meta_path)
    conditions = read_conditions(retest_meta_path)
    base_test, re_test = read_frf(baseline_path), read_frf(retest_path)
    order = match_points(point_positions_m(base_test), point_positions_m(re_test),
                         str(retest_path))
    baseline = fit_file(Path(baseline_path).name, base_test, meta.weight_kg, progress=progress)
    progress("calibrating the reference model to the baseline (diagnose)")
    reference = calibrate(profile, meta, baseline).reference
    retest = fit_file(Path(retest_path).name, re_test, meta.weight_kg, order, progress)
    progress("inspecting the re-test against the reference")
    verdict = inspect_modes(profile, reference, baseline.modes, retest.modes, false_alarm,
                            conditions, conditions_from_dict(meta.extra, meta_path))
    return InspectionResult(meta.serial, profile, reference, baseline, retest, verdict,
                            None, meta.weight_kg)


def inspect_registered(
    conn: sqlite3.Connection, serial: str, retest_path, false_alarm: float = 0.01,
    refit_baseline: bool = False, progress: Progress = _quiet, baseline_fit=None,
    retest_meta_path=None,
) -> InspectionResult:
    """Inspect a re-test of a registered bat against its stored reference and baseline modes.

    The stored baseline file is read (its checksum checked) to check the re-test's points and,
    with ``refit_baseline`` (for a report), to show its FRFs and stabilisation diagram;
    ``baseline_fit``: a fit of that same file already at hand (saves the refit).
    """
    conditions = read_conditions(retest_meta_path)
    bat = reg.get_bat(conn, serial)
    content = reg.baseline_file(conn, bat)
    base_test = frf_from_bytes(content, bat.baseline_name)
    if not Path(retest_path).is_file():
        raise ValueError(f"{retest_path}: no such file")
    retest_content = Path(retest_path).read_bytes()
    re_test = frf_from_bytes(retest_content, Path(retest_path).name, str(retest_path))
    base_modes = reg.decode_modes(bat.modes)
    order = match_points(base_modes.x_m, point_positions_m(re_test), str(retest_path))
    profile = make_profile(bat.profile_x_m, bat.profile_diameter_m, f"registry bat {serial}")
    weight = bat.meta.get("weight_lb")
    weight_kg = None if weight is None else float(weight) * LB_TO_KG
    fit = baseline_fit
    if refit_baseline and fit is None:
        fit = fit_file(bat.baseline_name, base_test, weight_kg, None, progress).fit
    baseline = FittedTest(bat.baseline_name, base_test, fit, base_modes)
    retest = fit_file(Path(retest_path).name, re_test, weight_kg, order, progress)
    reference = BatReference.from_dict(bat.reference)
    progress("inspecting the re-test against the registered reference")
    verdict = inspect_modes(profile, reference, base_modes, retest.modes, false_alarm,
                            conditions, conditions_from_dict(bat.meta,
                                                             f"registered bat {serial}"))
    return InspectionResult(serial, profile, reference, baseline, retest, verdict,
                            bat.reference_seq, weight_kg, retest_content)


def store_inspection(
    conn: sqlite3.Connection, result: InspectionResult, retest_path, false_alarm: float = 0.01,
) -> reg.Inspection:
    """Record an inspection of a registered bat: its verdict, a copy of the re-test file, the
    registration it was judged against and the inputs its report needs."""
    path = Path(retest_path)
    content = result.retest_content if result.retest_content is not None else \
        path.read_bytes()
    return reg.add_inspection(
        conn, result.serial, verdict_record(result.serial, result.verdict), path.name,
        content, reference_seq=result.reference_seq,
        inputs={"false_alarm": float(false_alarm), "batlab_version": __version__})


def provenance(
    conn: sqlite3.Connection | None = None, stored: reg.Inspection | None = None,
    baseline_sha256: str | None = None, retest_sha256: str | None = None,
) -> dict:
    """The facts a report prints to be verified: file hashes, and for a stored inspection its
    number, time and custody records (the verdict's and the registration's)."""
    out = {"batlab_version": __version__, "baseline_sha256": baseline_sha256,
           "retest_sha256": retest_sha256}
    if stored is not None and conn is not None:
        out.update({"inspection_id": stored.id, "inspected_at": stored.inspected_at,
                    "baseline_sha256": stored.baseline_sha256,
                    "retest_sha256": stored.retest_sha256,
                    "verdict_record": stored.record_seq, "verdict_record_sha256":
                    stored.record_sha256,
                    "verdict_sha256": reg.custody_record(conn, stored.record_seq).content_sha256,
                    "chain_head": reg.head(conn)})
        if stored.reference_seq is not None:
            ref = reg.custody_record(conn, stored.reference_seq)
            out.update({"reference_record": ref.seq, "reference_record_sha256":
                        ref.record_sha256})
        if stored.inputs:
            out["batlab_version"] = stored.inputs.get("batlab_version", __version__)
    return out


def report_inputs(result: InspectionResult, meta: dict, prov: dict) -> ReportInputs:
    """A fresh inspection's report inputs (the verdict as it is stored)."""
    return ReportInputs(result.serial, result.profile, result.reference, result.baseline,
                        result.retest, verdict_record(result.serial, result.verdict), meta, prov)


def file_sha256(path) -> str:
    return reg.sha256_bytes(Path(path).read_bytes())


def read_meta_dict(path) -> dict:
    """meta.json as read (for the report's provenance)."""
    return dict(read_meta(path).extra)


def stored_bat(conn: sqlite3.Connection, stored: reg.Inspection) -> reg.BatRecord:
    """The registration a stored inspection was judged against."""
    return reg.bat_as_registered(conn, stored.reference_seq)


def note_report(conn: sqlite3.Connection, stored: reg.Inspection, path: str) -> None:
    """Record where the inspection's report was written."""
    reg.set_report_path(conn, stored.id, path)


def stored_report_inputs(
    conn: sqlite3.Connection, serial: str, inspection_id: int | None = None,
    progress: Progress = _quiet,
) -> ReportInputs:
    """Rebuild a past inspection's report inputs from the registry alone: the verdict as
    stored, the registration it was judged against (custody record, also after
    ``register --replace``), and both test files read back (checksums verified) and refitted
    for the figures. ``inspection_id`` None: the bat's latest inspection."""
    rows = reg.history(conn, serial)
    if not rows:
        raise ValueError(f"bat {serial!r} has no inspection in the registry")
    if inspection_id is None:
        stored = rows[-1]
    else:
        match = [r for r in rows if r.id == inspection_id]
        if not match:
            raise ValueError(f"inspection #{inspection_id} is not one of bat {serial!r}'s "
                             f"(its inspections: {', '.join(str(r.id) for r in rows)})")
        stored = match[0]
    if stored.reference_seq is None:
        raise ValueError(f"inspection #{stored.id} of {serial!r} predates registry schema 3: "
                         "its re-test file and model were not kept, its report cannot be "
                         "rebuilt")
    bat = reg.bat_as_registered(conn, stored.reference_seq)
    base_name, base_bytes = reg.stored_file(conn, stored.baseline_sha256,
                                            f"inspection #{stored.id} baseline")
    re_name, re_bytes = reg.stored_file(conn, stored.retest_sha256,
                                        f"inspection #{stored.id} re-test")
    base_test = frf_from_bytes(base_bytes, bat.baseline_name or base_name)
    re_test = frf_from_bytes(re_bytes, stored.retest_name or re_name)
    base_modes = reg.decode_modes(bat.modes)
    order = match_points(base_modes.x_m, point_positions_m(re_test), stored.retest_name)
    weight = bat.meta.get("weight_lb")
    weight_kg = None if weight is None else float(weight) * LB_TO_KG
    base_fit = fit_file(bat.baseline_name, base_test, weight_kg, None, progress).fit
    retest = fit_file(stored.retest_name, re_test, weight_kg, order, progress)
    profile = make_profile(bat.profile_x_m, bat.profile_diameter_m, f"registry bat {serial}")
    return ReportInputs(
        serial, profile, BatReference.from_dict(bat.reference),
        FittedTest(bat.baseline_name, base_test, base_fit, base_modes), retest,
        stored.verdict, bat.meta, provenance(conn, stored=stored))


def history_table(conn: sqlite3.Connection, serial: str | None = None):
    """Every inspection (of one bat) as a pandas DataFrame, one row each, lab units: what
    `batlab export` writes."""
    import pandas as pd

    from batlab.formatting import p_value

    species = {b.serial: b.species for b in reg.list_bats(conn)}
    rows = []
    for i in reg.all_inspections(conn, serial):
        v = i.verdict
        region = v.get("region_in") or [None, None]
        rows.append({
            "serial": i.serial, "species": species.get(i.serial, ""), "inspection": i.id,
            "inspected_at": i.inspected_at, "status": i.status, "altered": i.altered,
            "region_start_in": region[0], "region_end_in": region[1],
            "core_diameter_in": v.get("core_diameter_in"),
            "fill_density_ratio": v.get("fill_density_ratio"),
            "p_value": p_value(v),
            "false_alarm_rate": v.get("false_alarm_rate"),
            "reasons": "; ".join(v.get("reasons") or []),
            "retest_file": i.retest_name, "retest_sha256": i.retest_sha256,
            "baseline_sha256": i.baseline_sha256, "registration_record": i.reference_seq,
            "verdict_record": i.record_seq, "verdict_record_sha256": i.record_sha256,
            "report_path": i.report_path})
    columns = ["serial", "species", "inspection", "inspected_at", "status", "altered",
               "region_start_in", "region_end_in", "core_diameter_in", "fill_density_ratio",
               "p_value", "false_alarm_rate", "reasons", "retest_file", "retest_sha256",
               "baseline_sha256", "registration_record", "verdict_record",
               "verdict_record_sha256", "report_path"]
    return pd.DataFrame(rows, columns=columns)


def write_csv(path, table) -> None:
    """A pandas DataFrame as CSV, atomically (temporary name, then rename)."""
    atomic_write(path, lambda tmp: table.to_csv(tmp, index=False))
