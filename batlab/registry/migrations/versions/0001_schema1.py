"""Schema 1: one row per bat with everything in JSON columns and the baseline inline.

Only ever run to build an old registry on purpose (tests of the upgrade path); a new registry
is created at the head from ``batlab.registry.schema``.

Revision ID: 0001
Revises:
"""

from alembic import op

from batlab.registry.migrations.legacy import script

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Create the schema-1 tables."""
    script(op.get_bind(), """
        CREATE TABLE bats (
            serial TEXT PRIMARY KEY,
            profile_json TEXT NOT NULL,
            meta_json TEXT NOT NULL,
            reference_json TEXT NOT NULL,
            modes_json TEXT NOT NULL,
            baseline_name TEXT NOT NULL,
            baseline_sha256 TEXT NOT NULL,
            baseline_blob BLOB NOT NULL,
            registered_at TEXT NOT NULL
        );
        CREATE TABLE inspections (
            id INTEGER PRIMARY KEY AUTOINCREMENT,
            serial TEXT NOT NULL REFERENCES bats(serial),
            verdict_json TEXT NOT NULL,
            retest_sha256 TEXT NOT NULL,
            inspected_at TEXT NOT NULL
        )
    """)
