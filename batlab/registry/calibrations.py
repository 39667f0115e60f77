"""Stored calibrations: a bat model's measured null, each with its signed custody record.

``batlab fleet calibrate --store`` keeps one row per model and run: the run's counts and, per
clean re-test, its statistic and status (``null_json``), and the code that judged them. The
custody record (kind ``calibration``, subject the row's id) holds the row's canonical JSON,
so ``registry check`` finds a changed, added or deleted calibration as it finds a changed
verdict. ``inspect`` reads the latest calibration of a bat's model (``latest_calibration``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import sqlalchemy as sa

from batlab.registry.chain import append_record, calibration_payload, canonical
from batlab.registry.common import now_utc, sha256_bytes
from batlab.registry.lock import transaction
from batlab.registry.schema import calibrations, custody


@dataclass(frozen=True)
class StoredCalibration:
    """A stored calibration of a bat model.

    Attributes
    ----------
    id : int
        Its number in the registry.
    model : str
        The bat model it measured.
    n : int
        Clean re-tests inspected.
    false_alarms : int
        Of them, called altered.
    false_alarm_upper95 : float
        The false-alarm rate's one-sided 95 % Clopper-Pearson bound.
    statistic : str
        The statistic's name (``F``).
    summary : dict
        The run: bat, seed, decision level, inconclusive/refused/not-altered counts, the
        codes that judged its rows, cost.
    null : dict
        Per clean re-test (lists in index order): ``index``, ``status``, the statistic
        (``F``; None when the re-test was refused or judged before the test), ``p`` and
        ``dof``.
    code : str
        The version of batlab that stored it.
    calibrated_at : str
        UTC time stamp.
    record_seq : int or None
        Its custody record.
    statistic_version : int or None
        The version of the statistic it measured (``STATISTIC_VERSION`` of the code that ran
        it; None: stored before versions were kept, unknown).
    origin : dict or None
        An imported calibration's signed file (``signer``, ``signature``, ``file_sha256``,
        ``batlab.registry.calibration_files``); None for one run here.
    """

    id: int
    model: str
    n: int
    false_alarms: int
    false_alarm_upper95: float
    statistic: str
    summary: dict
    null: dict
    code: str
    calibrated_at: str
    record_seq: int | None = None
    statistic_version: int | None = None
    origin: dict | None = None


def add_calibration(conn: sa.Connection, model: str, n: int, false_alarms: int,
                    false_alarm_upper95: float, statistic: str, summary: dict, null: dict,
                    code: str, statistic_version: int | None,
                    origin: dict | None = None,
                    calibrated_at: str | None = None) -> StoredCalibration:
    """Store a calibration and append its custody record, in one transaction.

    Parameters
    ----------
    conn : sa.Connection
        The registry.
    model, n, false_alarms, false_alarm_upper95, statistic, summary, null, code
        As ``StoredCalibration`` holds them (JSON types, no NaN: a missing value is None).
    statistic_version : int or None
        The version of the statistic the rows measured.
    origin : dict or None
        An imported calibration's signer and signature (None: run here).
    calibrated_at : str or None
        When it was run (default now; an import keeps the original's).

    Returns
    -------
    StoredCalibration
        The stored calibration.

    Raises
    ------
    ValueError
        An empty model name, or values JSON cannot hold exactly (NaN, infinity).
    """
    if not model.strip():
        raise ValueError("calibration: the bat model's name is empty")
    row = {"model": model, "n": int(n), "false_alarms": int(false_alarms),
           "false_alarm_upper95": float(false_alarm_upper95), "statistic": statistic,
           "summary_json": json.dumps(summary, allow_nan=False),
           "null_json": json.dumps(null, allow_nan=False), "code": code,
           "calibrated_at": calibrated_at or now_utc(), "statistic_version": statistic_version,
           "origin_json": None if origin is None else json.dumps(origin)}
    with transaction(conn):
        new_id = int(conn.execute(sa.insert(calibrations).values(**row))
                     .inserted_primary_key[0])
        seq = append_record(conn, "calibration", str(new_id), None,
                            canonical(calibration_payload(conn, new_id)))
        conn.execute(sa.update(calibrations).where(calibrations.c.id == new_id)
                     .values(record_seq=seq))
    return get_calibration(conn, new_id)


def _calibration(conn: sa.Connection, row) -> StoredCalibration:
    """Read a calibration, checked against its custody record (a number in a hearing)."""
    p = calibration_payload(conn, row[0])
    rec = conn.execute(sa.select(custody.c.payload, custody.c.content_sha256).where(
        custody.c.seq == row[1], custody.c.kind == "calibration",
        custody.c.subject == str(row[0]))).first()
    if rec is None or rec[0] != canonical(p) or sha256_bytes(rec[0].encode()) != rec[1]:
        raise ValueError(f"calibration #{row[0]} ({p['model']}) differs from its custody "
                         f"record #{row[1]} (registry tampered with or damaged; run `batlab "
                         "registry check`)")
    return StoredCalibration(p["id"], p["model"], p["n"], p["false_alarms"],
                             p["false_alarm_upper95"], p["statistic"], p["summary"], p["null"],
                             p["code"], p["calibrated_at"], row[1], p.get("statistic_version"),
                             p.get("origin"))


def get_calibration(conn: sa.Connection, calibration_id: int) -> StoredCalibration:
    """Return stored calibration ``calibration_id``; ValueError if there is none."""
    row = conn.execute(sa.select(calibrations.c.id, calibrations.c.record_seq)
                       .where(calibrations.c.id == calibration_id)).first()
    if row is None:
        raise ValueError(f"no calibration #{calibration_id} in the registry")
    return _calibration(conn, row)


def list_calibrations(conn: sa.Connection, model: str | None = None) -> list[StoredCalibration]:
    """Return every stored calibration (of one model when ``model``), oldest first."""
    q = sa.select(calibrations.c.id, calibrations.c.record_seq).order_by(calibrations.c.id)
    if model is not None:
        q = q.where(calibrations.c.model == model)
    return [_calibration(conn, r) for r in conn.execute(q)]


def latest_calibration(conn: sa.Connection, model: str) -> StoredCalibration | None:
    """Return the latest stored calibration of bat model ``model`` (None when there is none)."""
    row = conn.execute(sa.select(calibrations.c.id, calibrations.c.record_seq)
                       .where(calibrations.c.model == model)
                       .order_by(calibrations.c.id.desc()).limit(1)).first()
    return None if row is None else _calibration(conn, row)
