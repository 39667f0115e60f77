"""Schema 2: stations, species, baselines stored once by checksum, richer inspections.

Profile stations in their own table, a species column, baseline files stored once by
checksum; inspections record the baseline they were judged against, the verdict's decision
as a column, the re-test's file name and the report written. SQLite only (registries of this
age are files).

Revision ID: 0002
Revises: 0001
"""

import json

from alembic import op

from batlab.registry.migrations.legacy import script

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Rebuild bats and inspections, add baseline_files and stations."""
    conn = op.get_bind()
    profiles = conn.exec_driver_sql("SELECT serial, profile_json FROM bats").fetchall()
    script(conn, """
        CREATE TABLE baseline_files (
            sha256 TEXT PRIMARY KEY,
            name TEXT NOT NULL,
            size INTEGER NOT NULL,
            content BLOB NOT NULL
        );
        INSERT OR IGNORE INTO baseline_files (sha256, name, size, content)
            SELECT baseline_sha256, baseline_name, length(baseline_blob), baseline_blob FROM bats;
        CREATE TABLE bats_v2 (
            serial TEXT PRIMARY KEY,
            species TEXT NOT NULL,
            meta_json TEXT NOT NULL,
            reference_json TEXT NOT NULL,
            modes_json TEXT NOT NULL,
            baseline_sha256 TEXT NOT NULL REFERENCES baseline_files(sha256),
            registered_at TEXT NOT NULL
        );
        INSERT INTO bats_v2 SELECT serial, coalesce(json_extract(meta_json, '$.species'), ''),
            meta_json, reference_json, modes_json, baseline_sha256, registered_at FROM bats;
        CREATE TABLE inspections_v2 (
            id INTEGER PRIMARY KEY AUTOINCREMENT,
            serial TEXT NOT NULL REFERENCES bats_v2(serial),
            altered INTEGER NOT NULL,
            verdict_json TEXT NOT NULL,
            retest_name TEXT NOT NULL,
            retest_sha256 TEXT NOT NULL,
            baseline_sha256 TEXT NOT NULL,
            report_path TEXT,
            inspected_at TEXT NOT NULL
        );
        INSERT INTO inspections_v2 (id, serial, altered, verdict_json, retest_name,
                                    retest_sha256, baseline_sha256, report_path, inspected_at)
            SELECT i.id, i.serial, coalesce(json_extract(i.verdict_json, '$.altered'), 0),
                   i.verdict_json, '', i.retest_sha256, b.baseline_sha256, NULL, i.inspected_at
            FROM inspections i JOIN bats b ON b.serial = i.serial;
        DROP TABLE inspections;
        DROP TABLE bats;
        ALTER TABLE bats_v2 RENAME TO bats;
        ALTER TABLE inspections_v2 RENAME TO inspections;
        CREATE INDEX inspections_by_bat ON inspections (serial, inspected_at);
        CREATE TABLE stations (
            serial TEXT NOT NULL REFERENCES bats(serial) ON DELETE CASCADE,
            idx INTEGER NOT NULL,
            x_m REAL NOT NULL,
            diameter_m REAL NOT NULL,
            PRIMARY KEY (serial, idx)
        )
    """)
    rows = [(serial, i, float(x), float(d)) for serial, profile_json in profiles
            for prof in [json.loads(profile_json)]
            for i, (x, d) in enumerate(zip(prof["x_m"], prof["diameter_m"], strict=True))]
    if rows:
        conn.exec_driver_sql("INSERT INTO stations (serial, idx, x_m, diameter_m) "
                             "VALUES (?, ?, ?, ?)", rows)
