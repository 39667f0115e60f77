"""Schema 7: key records in the chain; calibrations name their statistic's version and origin.

A ``key`` custody kind (a key handed over or revoked, ``batlab.custody_keys``; the
``custody_kind`` check names it); ``calibrations.statistic_version`` (the version of F a
calibration measured, ``updating.inspect.nested.STATISTIC_VERSION``; NULL for calibrations
stored before: unknown, never used) and ``calibrations.origin_json`` (an imported
calibration's signed file: its signer and signature; NULL for one run here). Existing rows and
records stay as they are: a calibration's custody payload names the new columns only when
they hold a value. SQLite rebuilds ``custody`` (a CHECK constraint cannot change there) with
every row as it is; PostgreSQL drops and adds ``custody_kind``.

Revision ID: 0007
Revises: 0006
"""

import sqlalchemy as sa
from alembic import op

revision = "0007"
down_revision = "0006"
branch_labels = None
depends_on = None

KINDS = ("file", "reference", "verdict", "seal", "calibration", "key")
CUSTODY_KIND = "kind IN (" + ", ".join(f"'{k}'" for k in KINDS) + ")"
CUSTODY_COLUMNS = ("seq", "kind", "subject", "payload", "content_sha256", "prev_sha256",
                   "record_sha256", "recorded_at", "signer", "signature")


def _custody_v7(name: str) -> None:
    """Create the schema-7 custody table under ``name`` (its layout frozen here)."""
    op.create_table(
        name,
        sa.Column("seq", sa.Integer, primary_key=True, autoincrement=False),
        sa.Column("kind", sa.Text, nullable=False),
        sa.Column("subject", sa.Text, nullable=False),
        sa.Column("payload", sa.Text),
        sa.Column("content_sha256", sa.Text, nullable=False),
        sa.Column("prev_sha256", sa.Text, nullable=False),
        sa.Column("record_sha256", sa.Text, nullable=False),
        sa.Column("recorded_at", sa.Text, nullable=False),
        sa.Column("signer", sa.Text),
        sa.Column("signature", sa.Text),
        sa.CheckConstraint(CUSTODY_KIND, name="custody_kind"),
    )


def upgrade() -> None:
    """Add the calibrations' version and origin; let custody hold key records."""
    op.add_column("calibrations", sa.Column("statistic_version", sa.Integer))
    op.add_column("calibrations", sa.Column("origin_json", sa.Text))
    if op.get_bind().dialect.name == "sqlite":
        cols = ", ".join(CUSTODY_COLUMNS)
        _custody_v7("custody_v7")
        op.execute(f"INSERT INTO custody_v7 ({cols}) SELECT {cols} FROM custody")
        op.drop_table("custody")
        op.rename_table("custody_v7", "custody")
        op.create_index("custody_by_subject", "custody", ["kind", "subject"])
    else:
        op.drop_constraint("custody_kind", "custody", type_="check")
        op.create_check_constraint("custody_kind", "custody", CUSTODY_KIND)
