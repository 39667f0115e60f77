"""Schema 4: signed custody records and a ``seal`` kind; no ``inspections.altered``.

``signer`` and ``signature`` columns (``altered`` was written, never read: ``status`` says
it). Existing records stay unsigned legacy records; when there are any, a signed seal record
naming how many follows them, so they cannot be extended or stripped later without the lab's
key. SQLite only.

Revision ID: 0004
Revises: 0003
"""

from alembic import op

from batlab.registry.chain import append_record, canonical
from batlab.registry.migrations.legacy import script

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Rebuild custody with signer columns, drop inspections.altered, seal legacy records."""
    conn = op.get_bind()
    script(conn, """
        CREATE TABLE custody_v4 (
            seq INTEGER PRIMARY KEY,
            kind TEXT NOT NULL CHECK (kind IN ('file', 'reference', 'verdict', 'seal')),
            subject TEXT NOT NULL,
            payload TEXT,
            content_sha256 TEXT NOT NULL,
            prev_sha256 TEXT NOT NULL,
            record_sha256 TEXT NOT NULL,
            recorded_at TEXT NOT NULL,
            signer TEXT,
            signature TEXT
        );
        INSERT INTO custody_v4 (seq, kind, subject, payload, content_sha256, prev_sha256,
                                record_sha256, recorded_at)
            SELECT seq, kind, subject, payload, content_sha256, prev_sha256, record_sha256,
                   recorded_at FROM custody;
        DROP TABLE custody;
        ALTER TABLE custody_v4 RENAME TO custody;
        CREATE INDEX custody_by_subject ON custody (kind, subject);
        ALTER TABLE inspections DROP COLUMN altered
    """)
    n = conn.exec_driver_sql("SELECT count(*) FROM custody").scalar()
    if n:
        append_record(conn, "seal", "legacy", None, canonical({"legacy_records": n}))
