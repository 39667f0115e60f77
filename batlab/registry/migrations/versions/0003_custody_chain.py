"""Schema 3: every judged file kept and the hash-chained custody log.

``baseline_files`` becomes ``files`` (re-tests too); inspections name the reference record
they were judged against, their report inputs and their status; the ``custody`` table chains
every stored file, reference and verdict. Existing content is chained in the order files,
bats, inspections; an inspection made before schema 3 has no re-test file and no reference
record. SQLite only.

Revision ID: 0003
Revises: 0002
"""

import json

from alembic import op

from batlab.formatting import status_of
from batlab.registry.chain import append_legacy_record, bat_payload, canonical, inspection_payload
from batlab.registry.migrations.legacy import script

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Rename baseline_files, add the inspection columns and the custody chain."""
    conn = op.get_bind()
    script(conn, """
        ALTER TABLE baseline_files RENAME TO files;
        ALTER TABLE inspections ADD COLUMN status TEXT;
        ALTER TABLE inspections ADD COLUMN reference_seq INTEGER;
        ALTER TABLE inspections ADD COLUMN inputs_json TEXT;
        ALTER TABLE inspections ADD COLUMN record_seq INTEGER;
        CREATE TABLE custody (
            seq INTEGER PRIMARY KEY,
            kind TEXT NOT NULL CHECK (kind IN ('file', 'reference', 'verdict')),
            subject TEXT NOT NULL,
            payload TEXT,
            content_sha256 TEXT NOT NULL,
            prev_sha256 TEXT NOT NULL,
            record_sha256 TEXT NOT NULL,
            recorded_at TEXT NOT NULL
        );
        CREATE INDEX custody_by_subject ON custody (kind, subject)
    """)
    for sha, name in conn.exec_driver_sql("SELECT sha256, name FROM files ORDER BY rowid"
                                          ).fetchall():
        append_legacy_record(conn, "file", sha, sha, canonical({"name": name}))
    for (serial,) in conn.exec_driver_sql("SELECT serial FROM bats ORDER BY serial").fetchall():
        append_legacy_record(conn, "reference", serial, None, canonical(bat_payload(conn, serial)))
    for iid, verdict_json in conn.exec_driver_sql(
            "SELECT id, verdict_json FROM inspections ORDER BY id").fetchall():
        conn.exec_driver_sql("UPDATE inspections SET status = ? WHERE id = ?",
                             (status_of(json.loads(verdict_json)), iid))
        seq = append_legacy_record(conn, "verdict", str(iid), None,
                                   canonical(inspection_payload(conn, iid)))
        conn.exec_driver_sql("UPDATE inspections SET record_seq = ? WHERE id = ?", (seq, iid))
