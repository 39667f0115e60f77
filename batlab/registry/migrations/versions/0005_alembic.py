"""Schema 5: Alembic keeps the version; inspections found by their verdict record.

The hand-kept ``schema_version`` table is dropped (``alembic_version`` replaces it) and
``inspections_by_record`` indexes ``inspections.record_seq`` (a report's check looks an
inspection up by its verdict record). The first revision written for both dialects.

Revision ID: 0005
Revises: 0004
"""

from alembic import op

revision = "0005"
down_revision = "0004"
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Drop schema_version, index inspections.record_seq."""
    op.execute("DROP TABLE IF EXISTS schema_version")
    op.create_index("inspections_by_record", "inspections", ["record_seq"])
