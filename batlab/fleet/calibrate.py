"""`batlab fleet calibrate`'s work: clean re-tests of one bat inspected against its registration.

The bat (``clean_retests.draw_bat``) is drawn from child 0 of ``SeedSequence(seed)``, its
baseline simulated, written as the lab's files and registered by the pipeline's own steps
(``pipeline.prepare_registration``: the baseline's modal fit and the reference's
calibration) once per worker process (``registration`` caches it). Re-test ``i`` (1-based)
is drawn from child ``i`` (``child_seed``), simulated, written as a test file and read back,
fitted and judged as ``batlab inspect --serial`` judges it (``pipeline.fit_file``,
``pipeline.judge``) with its retest.json; no subprocess, no registry write, and no MSSO
element map (only a report draws it; the verdict is the same without it). The decision
reads the F distribution's chance, not a stored calibration's: a calibration measures F,
which no decision moves, and its false-alarm count is the nominal decision's
(``pipeline.chance.rows_bound_decision`` says where it bounds the measured one).

A long calibration can be resumed from its rows file (``read_rows``): the last stored
re-test is inspected again first and must give its stored status and F (``check_resumed``),
so rows from another bat, seed or version of batlab are never counted with these.

The tests are written as NPZ (the same doubles a binary UFF holds): pyuff's UFF writer leaves
its last text handle to be closed by the garbage collector, and in a Dask worker (whose
monitors hold frames) that handle was flushed late, out of order, twice in our runs.
"""

from __future__ import annotations

import json
import tempfile
import time
from dataclasses import dataclass, replace
from functools import cache, partial
from pathlib import Path

import numpy as np

import batlab.pipeline as pipeline
from batlab.fleet.clean_retests import CleanBat, draw_bat, draw_retest
from batlab.fleet.cluster import ordered_map
from batlab.pipeline.files import atomic_write
from batlab.pipeline.records import same_judgement
from batlab.pipeline.registered import (
    Registration,
    registered_weight_kg,
    registration_conditions,
)
from batlab.registry import decode_modes
from updating.inspect.retest_meta import conditions_from_dict
from updating.simulate.virtual_bat import simulate_test


@dataclass(frozen=True)
class BatSpec:
    """What names a calibration's bat: its lab files and the study's seed.

    Attributes
    ----------
    profile_path, meta_path : str
        profile.csv and meta.json.
    seed : int
        The study's seed.
    false_alarm : float
        The decision's false-alarm rate.
    """

    profile_path: str
    meta_path: str
    seed: int
    false_alarm: float = 0.01


def child_seed(seed: int, i: int) -> np.random.SeedSequence:
    """Return child ``i`` of ``SeedSequence(seed)``, as ``SeedSequence(seed).spawn(i + 1)[i]``.

    Made without spawning the ``i`` before it, so any worker draws bat ``i`` alone.
    """
    return np.random.SeedSequence(seed, spawn_key=(i,))


@dataclass(frozen=True)
class Registered:
    """A worker's cached registration of the calibration's bat.

    Attributes
    ----------
    bat : CleanBat
        The bat as drawn.
    registration : Registration
        Its registration (record, fitted baseline, calibrated reference).
    case : InspectionCase
        The case ``inspect --serial`` builds from the registry (profile, reference, baseline
        modes, registered conditions and weight), its re-test left None for each re-test.
    """

    bat: CleanBat
    registration: Registration
    case: object


def read_bat(spec: BatSpec) -> tuple:
    """Read the calibration's bat: its profile, meta.json's handbook wood and meta.json.

    Called by the client before any work is sent, so a bad file fails at once, naming it.

    Returns
    -------
    profile : Profile
        profile.csv.
    nominal : Material
        meta.json's handbook wood.
    meta : dict
        meta.json's content (with its ``points_in``).
    """
    profile = pipeline.bat_profile(spec.profile_path)
    nominal = pipeline.wood(spec.meta_path, None)
    meta = pipeline.read_meta_dict(spec.meta_path)
    if not meta.get("points_in"):
        raise ValueError(f"{spec.meta_path}: no points_in (the impact points) to test at")
    return profile, nominal, meta


@cache
def registration(spec: BatSpec) -> Registered:
    """Draw, simulate and register the calibration's bat (once per process and spec).

    The baseline's FRF noise has the study's seed; meta.json is the lab's with the scale's
    reading of this bat's weight.
    """
    profile, nominal, meta = read_bat(spec)
    bat = draw_bat(np.random.default_rng(child_seed(spec.seed, 0)), profile, nominal, meta)
    with tempfile.TemporaryDirectory(prefix="batlab-calibrate-") as tmp:
        meta_path = Path(tmp) / "meta.json"
        meta_path.write_text(json.dumps(bat.meta))
        base_path = Path(tmp) / "baseline.npz"
        pipeline.write_frf(base_path, simulate_test(bat.baseline, bat.freq_hz,
                                                    seed=int(spec.seed) % 2**31))
        done = pipeline.prepare_registration(spec.profile_path, meta_path, base_path)
    record = done.record
    baseline = pipeline.FittedTest(done.baseline.name, done.baseline.test, done.baseline.fit,
                                   decode_modes(record.modes))
    case = pipeline.InspectionCase(
        record.serial, profile, done.diagnosis.reference, baseline, None,
        registration_conditions(record.meta, record.serial), registered_weight_kg(record))
    return Registered(bat, done, case)


def inspect_clean(spec: BatSpec, i: int) -> dict:
    """Draw clean re-test ``i`` (1-based) of the calibration's bat and inspect it.

    Parameters
    ----------
    spec : BatSpec
        The bat and the study's seed.
    i : int
        The re-test's index (its seed is ``child_seed(spec.seed, i)``).

    Returns
    -------
    dict
        index, status ("not_altered", "inconclusive", "altered" or "refused"), reasons, the
        statistic F, its p-value and degrees of freedom, the grip, the code that judged it
        (``batlab.version``) and the seconds spent (simulation and inspection).
    """
    t0, cpu0 = time.perf_counter(), time.process_time()
    reg = registration(spec)
    retest = draw_retest(np.random.default_rng(child_seed(spec.seed, i)), reg.bat)
    row = {"index": i, "grip": retest.grip}
    with tempfile.TemporaryDirectory(prefix="batlab-calibrate-") as tmp:
        path = Path(tmp) / "retest.npz"
        pipeline.write_frf(path, simulate_test(retest.bat, reg.bat.freq_hz,
                                               seed=retest.noise_seed))
        try:
            test = pipeline.read_frf(path)
            fitted = pipeline.fit_file(path.name, test, reg.case.weight_kg)
            case = replace(reg.case, retest=fitted)
            verdict = pipeline.judge(case, spec.false_alarm, conditions_from_dict(
                retest.retest_meta, "retest.json"), with_map=False).verdict
        except ValueError as exc:  # refused, as `batlab inspect` refuses it
            row.update(status="refused", reasons=[str(exc)], F=None, p=None, dof=None,
                       code=pipeline.code_version(), seconds=time.perf_counter() - t0,
                       cpu_s=time.process_time() - cpu0)
            return row
    out = pipeline.contract_dict(reg.case.serial, verdict)
    fit = verdict.details.fit
    row.update(status=out["status"], reasons=out["reasons"], F=verdict.statistic,
               p=None if fit is None else fit.p_value,
               dof=None if fit is None or fit.dof is None else [int(d) for d in fit.dof],
               code=out["code"], seconds=time.perf_counter() - t0,
               cpu_s=time.process_time() - cpu0)
    return row


def upper95(false_alarms: int, n: int) -> float:
    """Return the one-sided 95 % Clopper-Pearson upper bound of a false-alarm rate.

    The rate p whose chance of ``false_alarms`` or fewer alarms in ``n`` bats is 5 %:
    ``beta.ppf(0.95, k + 1, n - k)``; at zero alarms ``1 - 0.05 ** (1 / n)`` (about 3 / n).

    Parameters
    ----------
    false_alarms : int
        Clean bats called altered.
    n : int
        Clean bats inspected.

    Returns
    -------
    float
        The upper bound (1 when every bat was an alarm).
    """
    from scipy.stats import beta

    if n <= 0:
        raise ValueError("no clean bat inspected: no bound")
    if false_alarms >= n:
        return 1.0
    return float(beta.ppf(0.95, false_alarms + 1, n - false_alarms))


def tail(rows: list[dict], k: int = 5) -> dict:
    """Summarise the statistic's tail over the inspected bats.

    Parameters
    ----------
    rows : list of dict
        ``inspect_clean``'s rows (those without a finite F, such as a refused or an
        inconclusive re-test judged before the test, are left out).
    k : int
        How many extreme values to list.

    Returns
    -------
    dict
        The ``k`` largest F with their bats' indices, the ``k`` smallest p-values, and the
        50, 90, 99 and 99.9 % quantiles of F and 1, 10 and 50 % of p.
    """
    scored = [r for r in rows if r.get("F") is not None and np.isfinite(r["F"])]
    with_p = [r for r in scored if r.get("p") is not None and np.isfinite(r["p"])]
    f = np.array([r["F"] for r in scored])
    p = np.array([r["p"] for r in with_p])
    by_f = sorted(scored, key=lambda r: -r["F"])[:k]
    by_p = sorted(with_p, key=lambda r: r["p"])[:k]
    out = {"largest_F": [{"index": r["index"], "F": r["F"], "status": r["status"]} for r in by_f],
           "smallest_p": [{"index": r["index"], "p": r["p"], "status": r["status"]}
                          for r in by_p]}
    if f.size:
        out["F_quantiles"] = {f"{q:g}": float(np.quantile(f, q / 100)) for q in (50, 90, 99, 99.9)}
    if p.size:
        out["p_quantiles"] = {f"{q:g}": float(np.quantile(p, q / 100)) for q in (1, 10, 50)}
    return out


def summary(rows: list[dict], spec: BatSpec, serial: str | None = None) -> dict:
    """Count the alarms of a calibration's rows and bound the false-alarm rate.

    Parameters
    ----------
    rows : list of dict
        ``inspect_clean``'s rows, one per clean re-test.
    spec : BatSpec
        The calibration's bat and seed.
    serial : str or None
        The bat's serial.

    Returns
    -------
    dict
        n, false_alarms (clean bats called altered), inconclusive, refused,
        false_alarm_upper95 (one-sided Clopper-Pearson, ``upper95``), confidence, the
        statuses per grip, the statistic's ``tail``, serial, seed, false_alarm, the code
        summarising (``code``) and the codes that judged the rows with their counts
        (``codes``), and the mean CPU seconds a row took (``cpu_s_per_bat``).
    """
    status = [r["status"] for r in rows]
    grips: dict = {}
    for r in rows:
        g = grips.setdefault(r["grip"] or "none", {})
        g[r["status"]] = g.get(r["status"], 0) + 1
    alarms = status.count("altered")
    cpu = [r["cpu_s"] for r in rows if r.get("cpu_s") is not None]
    return {"n": len(rows), "false_alarms": alarms, "inconclusive": status.count("inconclusive"),
            "refused": status.count("refused"), "not_altered": status.count("not_altered"),
            "false_alarm_upper95": upper95(alarms, len(rows)), "confidence": 0.95,
            "alarm_indices": [r["index"] for r in rows if r["status"] == "altered"],
            "by_grip": grips, "tail": tail(rows), "serial": serial, "seed": spec.seed,
            "false_alarm": spec.false_alarm, "code": pipeline.code_version(), "codes": codes(rows),
            "cpu_s_per_bat": float(np.mean(cpu)) if cpu else None}


UNNAMED_CODE = "unnamed"
"""The code of a row written before rows named theirs."""


def codes(rows: list[dict]) -> dict[str, int]:
    """Count the rows each code judged (``UNNAMED_CODE``: a row that does not say)."""
    out: dict[str, int] = {}
    for r in rows:
        name = r.get("code") or UNNAMED_CODE
        out[name] = out.get(name, 0) + 1
    return out


def run_calibration(client, spec: BatSpec, indices: list[int], progress,
                    on_row=None) -> list[dict]:
    """Inspect the clean re-tests ``indices`` of the bat on the cluster; rows in their order.

    ``on_row(row)`` sees each row as it comes back (a file of rows, say).
    """
    def keep(_: int, row: dict) -> dict:
        if on_row is not None:
            on_row(row)
        return row

    return ordered_map(client, partial(inspect_clean, spec), list(indices),
                       "clean bat", progress, keep)


def read_rows(path: str, n: int) -> tuple[list[dict], int]:
    """Read a calibration's rows file (``-o``): its rows of re-tests 1..n, one each.

    A last line cut short (the run was killed while writing it) is left out.

    Returns
    -------
    rows : list of dict
        The rows, in index order.
    cut : int
        Lines left out (0 or 1).

    Raises
    ------
    ValueError
        A line other than the last is not a row.
    """
    lines = Path(path).read_text().splitlines()
    rows: dict[int, dict] = {}
    cut = 0
    for k, line in enumerate(lines, start=1):
        try:
            row = json.loads(line)
            i = int(row["index"])
        except (ValueError, KeyError, TypeError):
            if k == len(lines):
                cut = 1
                continue
            raise ValueError(f"{path}: line {k} is not a calibration row") from None
        if 1 <= i <= n:
            rows[i] = row
    return [rows[i] for i in sorted(rows)], cut


def drop_cut_line(path: str) -> None:
    """Take a last line cut short off a rows file, atomically; every complete line stays."""
    text = Path(path).read_text()
    whole = text[:text.rfind("\n") + 1]
    atomic_write(path, lambda tmp: tmp.write_text(whole))


def same_row(stored: dict, again: dict, rtol: float = 1e-6) -> bool:
    """Say whether a re-test inspected again gives its stored row (``same_judgement``)."""
    return same_judgement(stored["status"], stored.get("F"), again["status"], again.get("F"),
                          rtol)


def check_resumed(path: str, stored: dict, again: dict) -> str | None:
    """Refuse to go on with rows another bat, seed or code made (``same_row``).

    Returns
    -------
    str or None
        When the re-test was judged again under other code than its row names and gave the
        same status and F: a line saying so, with both versions (None: the same code).

    Raises
    ------
    ValueError
        Naming the file, the re-test, both answers and both codes.
    """
    then, now = stored.get("code") or UNNAMED_CODE, again.get("code") or UNNAMED_CODE
    codes_said = f"stored by batlab {then}, judged again by batlab {now}"
    if not same_row(stored, again):
        raise ValueError(
            f"{path}: re-test {stored['index']} was stored as {stored['status']} "
            f"(F {stored.get('F')}) but is now {again['status']} (F {again.get('F')}); "
            f"{codes_said}: these rows come from another bat, seed or version of batlab")
    if then != now:
        return (f"re-test {stored['index']} judged again under other code ({codes_said}): "
                "the same status and F, so the rows are kept; the summary counts the rows "
                "each code judged")
    return None


def null_of(rows: list[dict]) -> dict:
    """Return what a stored calibration keeps of each clean re-test (lists in index order).

    ``index``, ``status``, ``F`` (None without one), ``p``, ``dof`` and ``code``, JSON
    types (NaN as None).
    """
    def num(v):
        return None if v is None or not np.isfinite(float(v)) else float(v)

    return {"index": [int(r["index"]) for r in rows], "status": [r["status"] for r in rows],
            "F": [num(r.get("F")) for r in rows], "p": [num(r.get("p")) for r in rows],
            "dof": [r.get("dof") for r in rows], "code": [r.get("code") for r in rows]}


def default_model(spec: BatSpec) -> str:
    """Return the bat model a calibration's profile and meta.json name (``model_name``)."""
    profile, _, meta = read_bat(spec)
    return pipeline.model_name(profile, str(meta.get("species", "")), meta)


def store_calibration(conn, model: str, rows: list[dict], out: dict):
    """Store a calibration's rows and summary as the model's measured null (signed record).

    Parameters
    ----------
    conn : sa.Connection
        The registry (written).
    model : str
        The bat model the calibration is of.
    rows : list of dict
        ``inspect_clean``'s rows, one per clean re-test, in index order.
    out : dict
        Their ``summary`` (with the run's cost).

    Returns
    -------
    StoredCalibration
        The stored calibration (its custody record in ``record_seq``).
    """
    from batlab.pipeline.chance import STATISTIC
    from batlab.registry import add_calibration
    from updating.inspect.nested import STATISTIC_VERSION

    keep = ("serial", "seed", "false_alarm", "inconclusive", "refused", "not_altered",
            "alarm_indices", "by_grip", "codes", "cpu_s_per_bat", "core_s_per_bat")
    summary = pipeline.jsonable({k: out.get(k) for k in keep})
    return add_calibration(conn, model, out["n"], out["false_alarms"],
                           out["false_alarm_upper95"], STATISTIC, summary, null_of(rows),
                           pipeline.code_version(), STATISTIC_VERSION)
