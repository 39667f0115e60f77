"""Bats, kept files and inspections: storing and reading them (SQLAlchemy Core, any dialect).

Every write runs in one ``transaction`` (the registry's write lock) and appends its custody
record in the same transaction, so a row and its record are stored together or not at all.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import sqlalchemy as sa

from batlab.custody import file_payload
from batlab.formatting import status_of
from batlab.registry.chain import (
    append_record,
    bat_payload,
    canonical,
    inspection_payload,
)
from batlab.registry.common import now_utc, sha256_bytes
from batlab.registry.lock import transaction
from batlab.registry.schema import bats, custody, files, inspections, stations

if TYPE_CHECKING:
    import numpy as np


@dataclass(frozen=True)
class BatRecord:
    """A registered bat, SI, in plain data (the pipeline turns it into model objects).

    Attributes
    ----------
        serial: the bat's serial number.
        profile_x_m, profile_diameter_m: profile stations from the knob end, m.
        meta: meta.json as read.
        species: wood species.
        reference: calibrated model parameters (``BatReference.to_dict()``).
        modes: fitted baseline modes: freq_hz, damping_ratio, shapes (points x modes), x_m,
            sensor_x_m, freq_std_hz (lists).
        baseline_name: the baseline file's original name (its extension says its format).
        baseline_sha256: checksum of the stored baseline file.
        registered_at: UTC time stamp.
        reference_seq: the custody record of this registration (0 before it is stored).
        code: the version of batlab that registered it (``batlab.version``; None for a bat
            registered before schema 6).
    """

    serial: str
    profile_x_m: list[float]
    profile_diameter_m: list[float]
    meta: dict
    species: str
    reference: dict
    modes: dict
    baseline_name: str = ""
    baseline_sha256: str = ""
    registered_at: str = ""
    reference_seq: int = 0
    code: str | None = None


@dataclass(frozen=True)
class BatSummary:
    """One line of ``batlab bats``: a bat, its inspection count and latest decision."""

    serial: str
    species: str
    registered_at: str
    n_inspections: int
    last_inspected_at: str | None
    last_altered: bool | None
    last_status: str | None = None


@dataclass(frozen=True)
class Inspection:
    """A stored inspection.

    ``altered`` is None when the verdict was inconclusive;
    ``reference_seq`` the custody record of the registration it was judged against (None
    before schema 3); ``record_seq``/``record_sha256`` its own custody record.
    """

    id: int
    serial: str
    altered: bool | None
    status: str
    verdict: dict
    retest_name: str
    retest_sha256: str
    baseline_sha256: str
    report_path: str | None
    inspected_at: str
    reference_seq: int | None = None
    inputs: dict | None = None
    record_seq: int | None = None
    record_sha256: str | None = None


class AlreadyStored(Exception):
    """``add_inspection(..., same_as=...)`` found the inspection stored already.

    Attributes
    ----------
    inspection : Inspection
        The stored inspection it repeats (nothing new was written).
    """

    def __init__(self, inspection: Inspection):
        super().__init__(f"inspection #{inspection.id} of {inspection.serial!r} is stored "
                         "already")
        self.inspection = inspection


def encode_modes(m) -> dict:
    """Return fitted modes as the registry stores them (``modes_json``): plain lists, SI.

    ``m`` is an ``updating.correlate.measured.MeasuredModes``.
    """
    import numpy as np

    noise = {} if m.shape_noise_rel is None else {
        "shape_noise_rel": np.asarray(m.shape_noise_rel).tolist()}
    return {"freq_hz": np.asarray(m.freq_hz).tolist(),
            "damping_ratio": np.asarray(m.damping_ratio).tolist(),
            "shapes": np.asarray(m.shapes).tolist(), "x_m": np.asarray(m.x_m).tolist(),
            "sensor_x_m": float(m.sensor_x_m),
            "freq_std_hz": None if m.freq_std_hz is None else np.asarray(m.freq_std_hz).tolist(),
            "band_top_hz": None if m.band_top_hz is None else float(m.band_top_hz),
            "members": None if m.members is None else np.asarray(m.members).tolist(),
            "plane_pair_hz": _pairs(m.plane_pair_hz),
            "plane_pair_std_hz": _pairs(m.plane_pair_std_hz), **noise}


def _pairs(a: np.ndarray | None) -> list | None:
    """Return the merged pairs' members (m, 2) as lists, NaN as None (JSON null)."""
    import numpy as np

    if a is None:
        return None
    return [[None if np.isnan(v) else float(v) for v in row] for row in np.asarray(a, float)]


def _unpairs(v: list | None) -> np.ndarray | None:
    """Inverse of ``_pairs`` (None: not recorded)."""
    import numpy as np

    if v is None:
        return None
    return np.array([[np.nan if x is None else x for x in row] for row in v],
                    dtype=float).reshape(-1, 2)


def decode_modes(d: dict):
    """Return the stored modes as ``MeasuredModes`` (shapes points x modes).

    Records stored before the band's top, the merged pairs, the pairs' members or the
    measured shape noise were kept read them as unknown (None).
    """
    import numpy as np

    from updating.correlate.measured import MeasuredModes

    std, members, noise = d.get("freq_std_hz"), d.get("members"), d.get("shape_noise_rel")
    return MeasuredModes(np.asarray(d["freq_hz"], float),
                         np.asarray(d["shapes"], float).reshape(len(d["x_m"]), -1),
                         np.asarray(d["x_m"], float), np.asarray(d["damping_ratio"], float),
                         float(d["sensor_x_m"]), None if std is None else np.asarray(std, float),
                         band_top_hz=d.get("band_top_hz"),
                         members=None if members is None else np.asarray(members, int),
                         plane_pair_hz=_unpairs(d.get("plane_pair_hz")),
                         plane_pair_std_hz=_unpairs(d.get("plane_pair_std_hz")),
                         shape_noise_rel=None if noise is None else np.asarray(noise, float))


def has_file(conn: sa.Connection, sha256: str) -> bool:
    """Return whether a file with this SHA-256 is stored."""
    return conn.execute(sa.select(1).where(files.c.sha256 == sha256)).first() is not None


def has_bat(conn: sa.Connection, serial: str) -> bool:
    """Return whether the serial is registered."""
    return conn.execute(sa.select(1).where(bats.c.serial == serial)).first() is not None


def store_file(conn: sa.Connection, name: str, content: bytes) -> str:
    """Keep a test file (inside the caller's transaction), once per content.

    A new file gets a custody record covering every column of its row
    (``custody.file_payload``: name, size and SHA-256 of the content); returns its SHA-256.
    """
    digest = sha256_bytes(content)
    if not has_file(conn, digest):
        conn.execute(sa.insert(files).values(sha256=digest, name=name, size=len(content),
                                             content=content))
        append_record(conn, "file", digest, None, file_payload(name, len(content), digest))
    return digest


def add_bat(
    conn: sa.Connection, bat: BatRecord, baseline_name: str, baseline: bytes,
    replace: bool = False,
) -> BatRecord:
    """Store a bat with a copy of its baseline file.

    ValueError if the serial exists and not ``replace``. Replacing keeps the bat's inspections,
    each naming the registration (custody record) it was judged against, and every file ever
    stored.
    """
    if not bat.serial.strip():
        raise ValueError("serial number is empty")
    stamp = now_utc()
    with transaction(conn):
        exists = has_bat(conn, bat.serial)
        if exists and not replace:
            raise ValueError(f"bat {bat.serial!r} is already registered (use --replace)")
        digest = store_file(conn, baseline_name, baseline)
        row = {"species": bat.species, "meta_json": json.dumps(bat.meta),
               "reference_json": json.dumps(bat.reference), "modes_json": json.dumps(bat.modes),
               "baseline_sha256": digest, "registered_at": stamp, "code": bat.code}
        if exists:
            conn.execute(sa.update(bats).where(bats.c.serial == bat.serial).values(**row))
            conn.execute(sa.delete(stations).where(stations.c.serial == bat.serial))
        else:
            conn.execute(sa.insert(bats).values(serial=bat.serial, **row))
        conn.execute(sa.insert(stations), [
            {"serial": bat.serial, "idx": i, "x_m": float(x), "diameter_m": float(d)}
            for i, (x, d) in enumerate(zip(bat.profile_x_m, bat.profile_diameter_m,
                                           strict=True))])
        append_record(conn, "reference", bat.serial, None,
                      canonical(bat_payload(conn, bat.serial)))
    return get_bat(conn, bat.serial)


def _bat_from_payload(p: dict, seq: int) -> BatRecord:
    return BatRecord(
        serial=p["serial"], profile_x_m=p["profile_x_m"],
        profile_diameter_m=p["profile_diameter_m"], meta=p["meta"], species=p["species"],
        reference=p["reference"], modes=p["modes"], baseline_name=p["baseline_name"],
        baseline_sha256=p["baseline_sha256"], registered_at=p["registered_at"],
        reference_seq=seq, code=p.get("code"))


def get_bat(conn: sa.Connection, serial: str) -> BatRecord:
    """Return the registered bat as it is now; ValueError naming the serial if unknown."""
    if not has_bat(conn, serial):
        raise ValueError(f"unknown serial {serial!r}: no such bat in the registry")
    seq = conn.execute(sa.select(sa.func.max(custody.c.seq)).where(
        custody.c.kind == "reference", custody.c.subject == serial)).scalar()
    return _bat_from_payload(bat_payload(conn, serial), int(seq or 0))


def bat_as_registered(conn: sa.Connection, reference_seq: int) -> BatRecord:
    """Return the bat as registration record ``reference_seq`` stored it.

    After a ``--replace`` the bat's current row differs; this is what an earlier inspection was
    judged against. The record's content is checked against its hash.
    """
    row = conn.execute(sa.select(custody.c.payload, custody.c.content_sha256).where(
        custody.c.seq == reference_seq, custody.c.kind == "reference")).first()
    if row is None:
        raise ValueError(f"registration record #{reference_seq} not in the registry")
    if sha256_bytes(row[0].encode("utf-8")) != row[1]:
        raise ValueError(f"registration record #{reference_seq} fails its SHA-256 checksum "
                         "(registry tampered with or damaged; run `batlab registry check`)")
    return _bat_from_payload(json.loads(row[0]), reference_seq)


def stored_file(conn: sa.Connection, sha256: str, what: str) -> tuple[str, bytes]:
    """Return (name, bytes) of a stored file after checking its SHA-256.

    ValueError naming ``what`` when it is missing or changed.
    """
    row = conn.execute(sa.select(files.c.name, files.c.content)
                       .where(files.c.sha256 == sha256)).first()
    if row is None:
        raise ValueError(f"{what}: file {sha256[:12]} missing from the registry")
    content = bytes(row[1])
    if sha256_bytes(content) != sha256:
        raise ValueError(f"{what}: stored {row[0]} fails its SHA-256 checksum (registry "
                         "tampered with or damaged)")
    return row[0], content


def baseline_file(conn: sa.Connection, bat: BatRecord) -> bytes:
    """Return the stored baseline file of ``bat`` after checking its SHA-256."""
    return stored_file(conn, bat.baseline_sha256, f"bat {bat.serial!r} baseline")[1]


_LIST_BATS = sa.text("""
    SELECT b.serial, b.species, b.registered_at, count(i.id), max(i.inspected_at),
           (SELECT status FROM inspections j WHERE j.serial = b.serial
            ORDER BY j.inspected_at DESC, j.id DESC LIMIT 1)
    FROM bats b LEFT JOIN inspections i ON i.serial = b.serial
    GROUP BY b.serial ORDER BY b.serial
""")


def list_bats(conn: sa.Connection) -> list[BatSummary]:
    """Return all bats by serial, with their inspection count and latest decision."""
    return [BatSummary(r[0], r[1], r[2], int(r[3]), r[4],
                       None if r[5] in (None, "inconclusive") else r[5] == "altered", r[5])
            for r in conn.execute(_LIST_BATS)]


def add_inspection(
    conn: sa.Connection, serial: str, verdict: dict, retest_name: str, retest: bytes,
    reference_seq: int | None = None, inputs: dict | None = None,
    report_path: str | None = None,
    same_as: Callable[[sa.Connection], Inspection | None] | None = None,
) -> Inspection:
    """Store one inspection of a registered bat.

    With its re-test file, the registration (custody record ``reference_seq``, default: the
    bat's current one) it was judged against and the report's other inputs; appends its verdict
    record to the custody chain. ``verdict`` holds ``status`` or ``altered``. ``same_as(conn)``,
    when given, runs inside the write transaction before anything is stored and returns an
    inspection already stored that this one repeats (None if none): then nothing is stored
    and ``AlreadyStored`` is raised with it, so two processes storing the same inspection at
    once store it once (the check and the store are one transaction).
    """
    stamp = now_utc()
    with transaction(conn):
        if not has_bat(conn, serial):
            raise ValueError(f"unknown serial {serial!r}: no such bat in the registry")
        done = None if same_as is None else same_as(conn)
        if done is not None:
            raise AlreadyStored(done)
        if reference_seq is None:
            reference_seq = get_bat(conn, serial).reference_seq
        ref = bat_as_registered(conn, reference_seq)
        if ref.serial != serial:
            raise ValueError(f"registration record #{reference_seq} is of bat {ref.serial!r}, "
                             f"not {serial!r}")
        digest = store_file(conn, retest_name, retest)
        new_id = int(conn.execute(sa.insert(inspections).values(
            serial=serial, status=status_of(verdict), verdict_json=json.dumps(verdict),
            retest_name=retest_name, retest_sha256=digest, baseline_sha256=ref.baseline_sha256,
            reference_seq=reference_seq, inputs_json=None if inputs is None else
            json.dumps(inputs), report_path=report_path, inspected_at=stamp)
        ).inserted_primary_key[0])
        seq = append_record(conn, "verdict", str(new_id), None,
                            canonical(inspection_payload(conn, new_id)))
        conn.execute(sa.update(inspections).where(inspections.c.id == new_id)
                     .values(record_seq=seq))
    return get_inspection(conn, new_id)


def set_report_path(conn: sa.Connection, inspection_id: int, report_path: str) -> None:
    """Note where the inspection's report was written (not part of its custody record)."""
    with transaction(conn):
        conn.execute(sa.update(inspections).where(inspections.c.id == inspection_id)
                     .values(report_path=report_path))


def _inspections_query():
    i = inspections.c
    return (sa.select(i.id, i.serial, i.status, i.verdict_json, i.retest_name, i.retest_sha256,
                      i.baseline_sha256, i.report_path, i.inspected_at, i.reference_seq,
                      i.inputs_json, i.record_seq, custody.c.record_sha256)
            .select_from(inspections.outerjoin(custody, custody.c.seq == i.record_seq)))


def _inspection(r) -> Inspection:
    status = r[2] or status_of(json.loads(r[3]))
    altered = None if status == "inconclusive" else status == "altered"
    return Inspection(r[0], r[1], altered, status, json.loads(r[3]), r[4], r[5], r[6], r[7],
                      r[8], r[9], None if r[10] is None else json.loads(r[10]), r[11], r[12])


def get_inspection(conn: sa.Connection, inspection_id: int) -> Inspection:
    """Return stored inspection ``inspection_id``; ValueError if there is none."""
    row = conn.execute(_inspections_query().where(inspections.c.id == inspection_id)).first()
    if row is None:
        raise ValueError(f"no inspection #{inspection_id} in the registry")
    return _inspection(row)


def inspection_by_record(conn: sa.Connection, record_seq: int) -> Inspection | None:
    """Return the inspection whose verdict record is ``record_seq`` (None if none is)."""
    row = conn.execute(_inspections_query().where(inspections.c.record_seq == record_seq)
                       .order_by(inspections.c.id)).first()
    return None if row is None else _inspection(row)


def history(conn: sa.Connection, serial: str) -> list[Inspection]:
    """Return the bat's inspections, oldest first; ValueError if the serial is unknown."""
    if not has_bat(conn, serial):
        raise ValueError(f"unknown serial {serial!r}: no such bat in the registry")
    i = inspections.c
    return [_inspection(r) for r in conn.execute(
        _inspections_query().where(i.serial == serial).order_by(i.inspected_at, i.id))]


def all_inspections(conn: sa.Connection, serial: str | None = None) -> list[Inspection]:
    """Return every inspection (of one bat when ``serial``), by bat then time."""
    if serial is not None:
        return history(conn, serial)
    i = inspections.c
    return [_inspection(r) for r in conn.execute(
        _inspections_query().order_by(i.serial, i.inspected_at, i.id))]
