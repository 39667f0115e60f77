"""Schema 6: stored calibrations (a bat model's measured null) and the code that registered.

A ``calibrations`` table (one row per ``fleet calibrate --store`` run: the model, its counts,
each clean re-test's statistic and status, the code that judged them), indexed by model;
a ``calibration`` custody kind (the ``custody_kind`` check names it); ``bats.code``, the
version that registered a bat (NULL for bats registered before). Written for both dialects:
SQLite cannot change a CHECK constraint, so there ``custody`` is rebuilt with its rows as
they are (same numbers, hashes and signatures); PostgreSQL drops and adds the constraint.

Revision ID: 0006
Revises: 0005
"""

import sqlalchemy as sa
from alembic import op

revision = "0006"
down_revision = "0005"
branch_labels = None
depends_on = None

KINDS = ("file", "reference", "verdict", "seal", "calibration")
CUSTODY_KIND = "kind IN (" + ", ".join(f"'{k}'" for k in KINDS) + ")"
CUSTODY_COLUMNS = ("seq", "kind", "subject", "payload", "content_sha256", "prev_sha256",
                   "record_sha256", "recorded_at", "signer", "signature")


def _custody_v6(name: str) -> None:
    """Create the schema-6 custody table under ``name`` (its layout frozen here)."""
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
    """Add calibrations and bats.code; let custody hold calibration records."""
    op.create_table(
        "calibrations",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("model", sa.Text, nullable=False),
        sa.Column("n", sa.Integer, nullable=False),
        sa.Column("false_alarms", sa.Integer, nullable=False),
        sa.Column("false_alarm_upper95", sa.Float, nullable=False),
        sa.Column("statistic", sa.Text, nullable=False),
        sa.Column("summary_json", sa.Text, nullable=False),
        sa.Column("null_json", sa.Text, nullable=False),
        sa.Column("code", sa.Text, nullable=False),
        sa.Column("calibrated_at", sa.Text, nullable=False),
        sa.Column("record_seq", sa.Integer),
        sqlite_autoincrement=True,
    )
    op.create_index("calibrations_by_model", "calibrations", ["model", "id"])
    op.add_column("bats", sa.Column("code", sa.Text))
    if op.get_bind().dialect.name == "sqlite":
        cols = ", ".join(CUSTODY_COLUMNS)
        _custody_v6("custody_v6")
        op.execute(f"INSERT INTO custody_v6 ({cols}) SELECT {cols} FROM custody")
        op.drop_table("custody")
        op.rename_table("custody_v6", "custody")
        op.create_index("custody_by_subject", "custody", ["kind", "subject"])
    else:
        op.drop_constraint("custody_kind", "custody", type_="check")
        op.create_check_constraint("custody_kind", "custody", CUSTODY_KIND)
