"""Appending to the custody chain and reading it back (format and check: batlab/custody.py).

Every append runs inside the caller's write transaction (``engine.transaction``), which holds
the registry's write lock, so the record read as the head is still the head when the next one
is written: concurrent writers queue, the chain never forks.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import sqlalchemy as sa

from batlab import custody, signing
from batlab.registry.common import now_utc, sha256_bytes
from batlab.registry.schema import (
    CUSTODY_COLUMNS,
    bats,
    calibrations,
    files,
    inspections,
    stations,
)
from batlab.registry.schema import custody as custody_table

GENESIS_SHA256 = custody.GENESIS_SHA256
record_hash = custody.legacy_record_hash
canonical = custody.canonical
_KEYS: dict[str, object] = {}


def forget_keys() -> None:
    """Forget the keys loaded (after the lab's key file was replaced: a rotation)."""
    _KEYS.clear()


def lab_key():
    """Return the lab's signing key (created on first write), loaded once per key file."""
    path = str(signing.key_path())
    if path not in _KEYS:
        _KEYS[path] = signing.signing_key(create=True)
    return _KEYS[path]


def lab_key_id() -> str:
    """Return the key id (``ed25519:<base64>``) this process signs records with."""
    return signing.key_id(lab_key().public_key())


def _last_record(conn: sa.Connection) -> tuple[int, str]:
    last = conn.execute(sa.select(custody_table.c.seq, custody_table.c.record_sha256)
                        .order_by(custody_table.c.seq.desc()).limit(1)).first()
    return (0, GENESIS_SHA256) if last is None else (int(last[0]), last[1])


def append_legacy_record(conn: sa.Connection, kind: str, subject: str,
                         content_sha256: str | None, payload: str | None) -> int:
    """Append an unsigned schema-3 record (migration 3 only); return its sequence number."""
    if content_sha256 is None:
        content_sha256 = sha256_bytes(payload.encode("utf-8"))
    seq, prev = _last_record(conn)
    seq += 1
    stamp = now_utc()
    conn.execute(sa.insert(custody_table).values(
        seq=seq, kind=kind, subject=subject, payload=payload, content_sha256=content_sha256,
        prev_sha256=prev, record_sha256=record_hash(seq, kind, subject, content_sha256, prev,
                                                    stamp),
        recorded_at=stamp))
    return seq


def next_record(conn: sa.Connection) -> tuple[int, str]:
    """Return the number and ``prev_sha256`` the next record will have (inside a transaction)."""
    seq, prev = _last_record(conn)
    return seq + 1, prev


def append_record(conn: sa.Connection, kind: str, subject: str,
                  content_sha256: str | None, payload: str | None, key=None) -> int:
    """Append a signed custody record (inside the caller's transaction).

    ``content_sha256`` defaults to the hash of ``payload``; ``key`` (an Ed25519 private key)
    to the lab's; returns the record's number.
    """
    if content_sha256 is None:
        content_sha256 = sha256_bytes(payload.encode("utf-8"))
    key = lab_key() if key is None else key
    signer = signing.key_id(key.public_key())
    seq, prev = next_record(conn)
    stamp = now_utc()
    data = custody.record_bytes(seq, kind, subject, content_sha256, prev, stamp, signer)
    conn.execute(sa.insert(custody_table).values(
        seq=seq, kind=kind, subject=subject, payload=payload, content_sha256=content_sha256,
        prev_sha256=prev, record_sha256=sha256_bytes(data), recorded_at=stamp, signer=signer,
        signature=signing.sign(key, data)))
    return seq


def bat_payload(conn: sa.Connection, serial: str) -> dict:
    """Return what a reference record holds: the bat's row and profile as stored now.

    ``code`` (the version that registered it) only when the row has one, so a registration
    stored before schema 6 still equals its record.
    """
    # every column there is: migration 3 builds its records with this function, on a table
    # without the columns of later schemas (``code``, schema 6)
    row = conn.execute(sa.select(sa.text("*")).select_from(bats)
                       .where(bats.c.serial == serial)).mappings().first()
    profile = conn.execute(sa.select(stations.c.x_m, stations.c.diameter_m)
                           .where(stations.c.serial == serial).order_by(stations.c.idx)).all()
    name = conn.execute(sa.select(files.c.name)
                        .where(files.c.sha256 == row["baseline_sha256"])).first()
    out = {"serial": row["serial"], "species": row["species"],
           "meta": json.loads(row["meta_json"]), "reference": json.loads(row["reference_json"]),
           "modes": json.loads(row["modes_json"]), "baseline_sha256": row["baseline_sha256"],
           "baseline_name": name[0] if name else "", "registered_at": row["registered_at"],
           "profile_x_m": [s[0] for s in profile],
           "profile_diameter_m": [s[1] for s in profile]}
    if row.get("code") is not None:  # the code that registered it (schema 6; absent before)
        out["code"] = row["code"]
    return out


def inspection_payload(conn: sa.Connection, inspection_id: int) -> dict:
    """Return what a verdict record holds: the inspection's row as stored now.

    All but ``report_path`` (a note of where a copy of the report was written) and
    ``record_seq``.
    """
    i = inspections.c
    row = conn.execute(sa.select(i.id, i.serial, i.status, i.verdict_json, i.retest_name,
                                 i.retest_sha256, i.baseline_sha256, i.reference_seq,
                                 i.inputs_json, i.inspected_at)
                       .where(i.id == inspection_id)).first()
    return {"id": row[0], "serial": row[1], "status": row[2], "verdict": json.loads(row[3]),
            "retest_name": row[4], "retest_sha256": row[5], "baseline_sha256": row[6],
            "reference_seq": row[7], "inputs": None if row[8] is None else json.loads(row[8]),
            "inspected_at": row[9]}


def calibration_payload(conn: sa.Connection, calibration_id: int) -> dict:
    """Return what a calibration record holds: the calibration's row as stored now.

    All but ``record_seq``; the row's JSON columns as the objects they hold;
    ``statistic_version`` and ``origin`` (schema 7) only when set.
    """
    c = calibrations.c
    row = conn.execute(sa.select(c.id, c.model, c.n, c.false_alarms, c.false_alarm_upper95,
                                 c.statistic, c.summary_json, c.null_json, c.code,
                                 c.calibrated_at, c.statistic_version, c.origin_json)
                       .where(c.id == calibration_id)).first()
    out = {"id": row[0], "model": row[1], "n": row[2], "false_alarms": row[3],
           "false_alarm_upper95": row[4], "statistic": row[5],
           "summary": json.loads(row[6]), "null": json.loads(row[7]), "code": row[8],
           "calibrated_at": row[9]}
    # schema 7's columns only when they hold a value, so a calibration stored before still
    # equals its record
    if row[10] is not None:
        out["statistic_version"] = row[10]
    if row[11] is not None:
        out["origin"] = json.loads(row[11])
    return out


@dataclass(frozen=True)
class CustodyRecord:
    """A custody record's identity: number, kind, subject, hashes, time and signer."""

    seq: int
    kind: str
    subject: str
    content_sha256: str
    prev_sha256: str
    record_sha256: str
    recorded_at: str
    signer: str | None = None


def custody_record(conn: sa.Connection, seq: int) -> CustodyRecord:
    """Return custody record ``seq``; ValueError if it is not in the registry."""
    c = custody_table.c
    row = conn.execute(sa.select(c.seq, c.kind, c.subject, c.content_sha256, c.prev_sha256,
                                 c.record_sha256, c.recorded_at, c.signer)
                       .where(c.seq == seq)).first()
    if row is None:
        raise ValueError(f"custody record #{seq} not in the registry")
    return CustodyRecord(*row)


def chain_head(conn: sa.Connection) -> CustodyRecord | None:
    """Return the last custody record (its hash seals everything before it)."""
    last = conn.execute(sa.select(sa.func.max(custody_table.c.seq))).scalar()
    return None if last is None else custody_record(conn, int(last))


def head(conn: sa.Connection) -> str | None:
    """Return the head of the chain as ``SEQ:SHA256`` (None for an empty registry)."""
    last = chain_head(conn)
    return None if last is None else custody.head_text(last.seq, last.record_sha256)


def custody_rows(conn: sa.Connection) -> list[custody.Row]:
    """Return every custody record, in sequence order."""
    cols = [custody_table.c[name] for name in CUSTODY_COLUMNS]
    return [custody.Row(*r) for r in conn.execute(
        sa.select(*cols).order_by(custody_table.c.seq))]
