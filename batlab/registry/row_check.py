"""A stored inspection read back against its signed verdict record, before anything uses it.

``registry check`` verifies the whole registry; a report drawn from one inspection must not
wait for it: ``verdict_differences`` compares the inspection's row with its own custody
record (the record's hash, content hash and signature, then field by field) and says what
differs, so ``batlab report`` refuses a verdict edited after it was signed.
"""

from __future__ import annotations

import json

import sqlalchemy as sa

from batlab import custody
from batlab.registry.chain import inspection_payload
from batlab.registry.schema import CUSTODY_COLUMNS
from batlab.registry.schema import custody as custody_table

SHOWN = 3
"""How many differing fields a message names."""


def _short(value) -> str:
    text = json.dumps(value, sort_keys=True)
    return text if len(text) <= 40 else text[:37] + "..."


def _differences(record: dict, row: dict, prefix: str = "") -> list[str]:
    """Return ``key: X in the record, Y in the row`` for each differing field (nested dicts)."""
    out = []
    for key in sorted(set(record) | set(row)):
        a, b = record.get(key), row.get(key)
        if isinstance(a, dict) and isinstance(b, dict):
            out += _differences(a, b, f"{prefix}{key}.")
        elif a != b:
            out.append(f"{prefix}{key}: {_short(a)} in the record, {_short(b)} in the row")
    return out


def verdict_differences(conn: sa.Connection, inspection_id: int, record_seq: int | None,
                        ) -> list[str]:
    """Return what differs between a stored inspection and its verdict record (empty: none).

    Parameters
    ----------
    conn : sqlalchemy.Connection
        The registry.
    inspection_id : int
        The inspection.
    record_seq : int or None
        The custody record its row names (``inspections.record_seq``).

    Returns
    -------
    list of str
        One line each: the record missing or of another inspection, the record failing its
        own hash, content hash or signature, or the fields whose values differ.
    """
    c = custody_table.c
    row = None if record_seq is None else conn.execute(
        sa.select(*[c[n] for n in CUSTODY_COLUMNS]).where(c.seq == record_seq)).first()
    if row is None:
        return [f"its verdict record #{record_seq} is not in the registry"]
    rec = custody.Row(*row)
    if rec.kind != "verdict" or rec.subject != str(inspection_id):
        return [f"record #{rec.seq} is a {rec.kind} record of {rec.subject!r}, not this "
                "inspection's verdict"]
    if rec.record_sha256 != rec.expected_hash() or \
            custody.sha256_text(rec.payload or "") != rec.content_sha256:
        return [f"verdict record #{rec.seq} fails its own hash"]
    if rec.signer is not None and not rec.signature_ok():
        return [f"verdict record #{rec.seq}'s signature does not verify"]
    stored = json.loads(custody.canonical(inspection_payload(conn, inspection_id)))
    said = _differences(json.loads(rec.payload), stored)
    more = len(said) - SHOWN
    return said[:SHOWN] + ([f"{more} more field(s)"] if more > 0 else [])
