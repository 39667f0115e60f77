"""The registry's tables, one SQLAlchemy Core metadata for SQLite and PostgreSQL (schema 7).

``files`` keeps every judged file once by its SHA-256; ``bats`` and ``stations`` the
registered bats; ``inspections`` every stored verdict; ``calibrations`` the measured nulls of
bat models (``fleet calibrate --store``); ``custody`` the signed hash chain over all of them
(batlab/custody.py). Migrations to this layout: ``batlab/registry/migrations``.
"""

from __future__ import annotations

import sqlalchemy as sa

from batlab import custody as _custody

metadata = sa.MetaData()

files = sa.Table(
    "files", metadata,
    sa.Column("sha256", sa.Text, primary_key=True),
    sa.Column("name", sa.Text, nullable=False),
    sa.Column("size", sa.Integer, nullable=False),
    sa.Column("content", sa.LargeBinary, nullable=False),
)

bats = sa.Table(
    "bats", metadata,
    sa.Column("serial", sa.Text, primary_key=True),
    sa.Column("species", sa.Text, nullable=False),
    sa.Column("meta_json", sa.Text, nullable=False),
    sa.Column("reference_json", sa.Text, nullable=False),
    sa.Column("modes_json", sa.Text, nullable=False),
    sa.Column("baseline_sha256", sa.Text, sa.ForeignKey("files.sha256"), nullable=False),
    sa.Column("registered_at", sa.Text, nullable=False),
    sa.Column("code", sa.Text),  # the version that registered it (NULL before schema 6)
)

stations = sa.Table(
    "stations", metadata,
    sa.Column("serial", sa.Text, sa.ForeignKey("bats.serial", ondelete="CASCADE"),
              primary_key=True),
    sa.Column("idx", sa.Integer, primary_key=True, autoincrement=False),
    sa.Column("x_m", sa.Float, nullable=False),
    sa.Column("diameter_m", sa.Float, nullable=False),
)

inspections = sa.Table(
    "inspections", metadata,
    sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
    sa.Column("serial", sa.Text, sa.ForeignKey("bats.serial"), nullable=False),
    sa.Column("verdict_json", sa.Text, nullable=False),
    sa.Column("retest_name", sa.Text, nullable=False),
    sa.Column("retest_sha256", sa.Text, nullable=False),
    sa.Column("baseline_sha256", sa.Text, nullable=False),
    sa.Column("report_path", sa.Text),
    sa.Column("inspected_at", sa.Text, nullable=False),
    sa.Column("status", sa.Text),
    sa.Column("reference_seq", sa.Integer),
    sa.Column("inputs_json", sa.Text),
    sa.Column("record_seq", sa.Integer),
    sa.Index("inspections_by_bat", "serial", "inspected_at"),
    sa.Index("inspections_by_record", "record_seq"),
    sqlite_autoincrement=True,
)

calibrations = sa.Table(
    "calibrations", metadata,
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
    sa.Column("statistic_version", sa.Integer),  # F's version (NULL before schema 7: unknown)
    sa.Column("origin_json", sa.Text),  # an imported calibration's signer and signature
    sa.Index("calibrations_by_model", "model", "id"),
    sqlite_autoincrement=True,
)

custody = sa.Table(
    "custody", metadata,
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
    sa.CheckConstraint("kind IN (" + ", ".join(f"'{k}'" for k in _custody.KINDS) + ")",
                       name="custody_kind"),
    sa.Index("custody_by_subject", "kind", "subject"),
)

TABLES = (files, bats, stations, inspections, calibrations, custody)
"""Every table, parents before children (the order a copy inserts them in)."""

CUSTODY_COLUMNS = tuple(c.name for c in custody.columns)
