"""The lab's registry of bats: SQLite, one file, safe with concurrent writers.

A bat is registered once under its serial number with its profile (stations), meta.json,
species, calibrated model parameters (``BatReference.to_dict()``), the baseline FRF file itself
(copied in, keyed by its SHA-256 and checked on every read) and the baseline's fitted modes.
Every later inspection is stored with its verdict, the re-test file's checksum and the time.

Safety: WAL journal, ``busy_timeout``, every write in one ``BEGIN IMMEDIATE`` transaction, so
concurrent writers queue instead of failing and a process killed mid-transaction leaves the
last committed state. The schema carries its version in ``schema_version``; ``MIGRATIONS[v]``
brings a database from version v - 1 to v and runs in the same transaction as the version bump.
Layout and migrations: docs/registry.md.
"""

from __future__ import annotations

import hashlib
import json
import os
import sqlite3
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

BUSY_TIMEOUT_S = 60.0


def default_db_path(env: dict | None = None) -> Path:
    """``$BATLAB_DB``, else ``$XDG_DATA_HOME/batlab/registry.sqlite``, else
    ``~/.local/share/batlab/registry.sqlite``."""
    env = os.environ if env is None else env
    if env.get("BATLAB_DB"):
        return Path(env["BATLAB_DB"]).expanduser()
    base = env.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base).expanduser() / "batlab" / "registry.sqlite"


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def now_utc() -> str:
    """ISO 8601 UTC time stamp with microseconds (sorts as text)."""
    return datetime.now(timezone.utc).isoformat(timespec="microseconds")


# ---------------------------------------------------------------------------------------------
# Schema and migrations


def _script(conn: sqlite3.Connection, sql: str) -> None:
    """Run ``;``-separated statements inside the current transaction (``executescript``
    would commit it)."""
    for stmt in sql.split(";"):
        if stmt.strip():
            conn.execute(stmt)


def _migrate_1(conn: sqlite3.Connection) -> None:
    """Version 1: one row per bat with everything in JSON columns and the baseline inline."""
    _script(conn, """
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


def _migrate_2(conn: sqlite3.Connection) -> None:
    """Version 2: profile stations in their own table, species column, baseline files stored
    once by checksum, inspections record the baseline they were judged against, the verdict's
    decision as a column, the re-test's file name and the report written."""
    profiles = conn.execute("SELECT serial, profile_json FROM bats").fetchall()
    _script(conn, """
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
    for serial, profile_json in profiles:
        prof = json.loads(profile_json)
        conn.executemany(
            "INSERT INTO stations (serial, idx, x_m, diameter_m) VALUES (?, ?, ?, ?)",
            [(serial, i, float(x), float(d))
             for i, (x, d) in enumerate(zip(prof["x_m"], prof["diameter_m"], strict=True))])


MIGRATIONS: dict[int, Callable[[sqlite3.Connection], None]] = {1: _migrate_1, 2: _migrate_2}
SCHEMA_VERSION = max(MIGRATIONS)


def schema_version(conn: sqlite3.Connection) -> int:
    """The database's schema version (0 for an empty database)."""
    has = conn.execute(
        "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'schema_version'").fetchone()
    if not has:
        return 0
    row = conn.execute("SELECT max(version) FROM schema_version").fetchone()
    return int(row[0] or 0)


def migrate(conn: sqlite3.Connection, target: int = SCHEMA_VERSION) -> int:
    """Bring the database up to ``target``, one migration per transaction; returns the version.

    Each step re-reads the version under the write lock, so two processes opening an old
    database at once migrate it once.
    """
    if target not in MIGRATIONS:
        raise ValueError(f"unknown registry schema version {target}")
    while True:
        with transaction(conn):
            version = schema_version(conn)
            if version > SCHEMA_VERSION:
                raise ValueError(f"registry schema version {version} is newer than this batlab "
                                 f"({SCHEMA_VERSION}); upgrade batlab")
            if version >= target:
                return version
            if version == 0:
                conn.execute("CREATE TABLE schema_version (version INTEGER NOT NULL, "
                             "applied_at TEXT NOT NULL)")
            MIGRATIONS[version + 1](conn)
            conn.execute("INSERT INTO schema_version (version, applied_at) VALUES (?, ?)",
                         (version + 1, now_utc()))


# ---------------------------------------------------------------------------------------------
# Connections and transactions


def connect(
    path: str | os.PathLike, target: int = SCHEMA_VERSION, create: bool = True,
) -> sqlite3.Connection:
    """Open the registry at ``path`` (creating it if ``create``) and migrate it to ``target``."""
    path = Path(path)
    if path.exists() and path.is_dir():
        raise ValueError(f"{path}: registry path is a directory")
    if not create and not path.exists():
        raise ValueError(f"{path}: no registry there (register a bat first, or give --db)")
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        conn = sqlite3.connect(path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        conn.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
        conn.execute("PRAGMA journal_mode = WAL")
        conn.execute("PRAGMA synchronous = FULL")
        conn.execute("PRAGMA foreign_keys = ON")
        migrate(conn, target)
    except sqlite3.DatabaseError as exc:
        raise ValueError(f"{path}: not a usable batlab registry ({exc})") from None
    return conn


@contextmanager
def transaction(conn: sqlite3.Connection) -> Iterator[sqlite3.Connection]:
    """``BEGIN IMMEDIATE`` ... ``COMMIT``; rolled back on any exception (or never committed
    if the process dies)."""
    conn.execute("BEGIN IMMEDIATE")
    try:
        yield conn
    except BaseException:
        conn.execute("ROLLBACK")
        raise
    conn.execute("COMMIT")


@contextmanager
def open_registry(path: str | os.PathLike, create: bool = True) -> Iterator[sqlite3.Connection]:
    """``connect`` as a context manager that closes the connection."""
    conn = connect(path, create=create)
    try:
        yield conn
    finally:
        conn.close()


# ---------------------------------------------------------------------------------------------
# Records


@dataclass(frozen=True)
class BatRecord:
    """A registered bat, SI, in plain data (the pipeline turns it into model objects).

    Attributes:
        serial: the bat's serial number.
        profile_x_m, profile_diameter_m: profile stations from the knob end, m.
        meta: meta.json as read.
        species: wood species.
        reference: calibrated model parameters (``BatReference.to_dict()``).
        modes: fitted baseline modes: freq_hz, damping_ratio, shapes (points x modes), x_m,
            sensor_x_m, freq_std_hz (lists).
        baseline_name: the baseline file's original name (its extension says its format).
        baseline_sha256: checksum of the stored baseline file.
        registered_at: UTC time stamp.
    """

    serial: str
    profile_x_m: list[float]
    profile_diameter_m: list[float]
    meta: dict
    species: str
    reference: dict
    modes: dict
    baseline_name: str = ""
    baseline_sha256: str = ""
    registered_at: str = ""


@dataclass(frozen=True)
class BatSummary:
    serial: str
    species: str
    registered_at: str
    n_inspections: int
    last_inspected_at: str | None
    last_altered: bool | None


@dataclass(frozen=True)
class Inspection:
    id: int
    serial: str
    altered: bool
    verdict: dict
    retest_name: str
    retest_sha256: str
    baseline_sha256: str
    report_path: str | None
    inspected_at: str


def add_bat(
    conn: sqlite3.Connection, bat: BatRecord, baseline_name: str, baseline: bytes,
    replace: bool = False,
) -> BatRecord:
    """Store a bat with a copy of its baseline file; ValueError if the serial exists and not
    ``replace``. Replacing keeps the bat's inspections (each names its own baseline)."""
    if not bat.serial.strip():
        raise ValueError("serial number is empty")
    digest = sha256_bytes(baseline)
    stamp = now_utc()
    with transaction(conn):
        exists = conn.execute("SELECT 1 FROM bats WHERE serial = ?", (bat.serial,)).fetchone()
        if exists and not replace:
            raise ValueError(f"bat {bat.serial!r} is already registered (use --replace)")
        conn.execute("INSERT OR IGNORE INTO baseline_files (sha256, name, size, content) "
                     "VALUES (?, ?, ?, ?)", (digest, baseline_name, len(baseline), baseline))
        row = (bat.species, json.dumps(bat.meta), json.dumps(bat.reference),
               json.dumps(bat.modes), digest, stamp, bat.serial)
        if exists:
            conn.execute("UPDATE bats SET species = ?, meta_json = ?, reference_json = ?, "
                         "modes_json = ?, baseline_sha256 = ?, registered_at = ? "
                         "WHERE serial = ?", row)
            conn.execute("DELETE FROM stations WHERE serial = ?", (bat.serial,))
        else:
            conn.execute("INSERT INTO bats (species, meta_json, reference_json, modes_json, "
                         "baseline_sha256, registered_at, serial) VALUES (?, ?, ?, ?, ?, ?, ?)",
                         row)
        conn.executemany(
            "INSERT INTO stations (serial, idx, x_m, diameter_m) VALUES (?, ?, ?, ?)",
            [(bat.serial, i, float(x), float(d)) for i, (x, d) in
             enumerate(zip(bat.profile_x_m, bat.profile_diameter_m, strict=True))])
        conn.execute("DELETE FROM baseline_files WHERE sha256 NOT IN "
                     "(SELECT baseline_sha256 FROM bats) AND sha256 NOT IN "
                     "(SELECT baseline_sha256 FROM inspections)")
    return get_bat(conn, bat.serial)


def get_bat(conn: sqlite3.Connection, serial: str) -> BatRecord:
    """The registered bat; ValueError naming the serial if it is unknown."""
    row = conn.execute(
        "SELECT b.serial, b.meta_json, b.species, b.reference_json, b.modes_json, f.name, "
        "b.baseline_sha256, b.registered_at FROM bats b "
        "JOIN baseline_files f ON f.sha256 = b.baseline_sha256 WHERE b.serial = ?",
        (serial,)).fetchone()
    if row is None:
        raise ValueError(f"unknown serial {serial!r}: no such bat in the registry")
    stations = conn.execute("SELECT x_m, diameter_m FROM stations WHERE serial = ? ORDER BY idx",
                            (serial,)).fetchall()
    return BatRecord(
        serial=row[0], profile_x_m=[s[0] for s in stations],
        profile_diameter_m=[s[1] for s in stations], meta=json.loads(row[1]), species=row[2],
        reference=json.loads(row[3]), modes=json.loads(row[4]), baseline_name=row[5],
        baseline_sha256=row[6], registered_at=row[7])


def baseline_file(conn: sqlite3.Connection, bat: BatRecord) -> bytes:
    """The stored baseline file of ``bat``, after checking its SHA-256; ValueError on mismatch."""
    row = conn.execute("SELECT content FROM baseline_files WHERE sha256 = ?",
                       (bat.baseline_sha256,)).fetchone()
    if row is None:
        raise ValueError(f"bat {bat.serial!r}: baseline file {bat.baseline_sha256[:12]} missing "
                         "from the registry")
    content = bytes(row[0])
    if sha256_bytes(content) != bat.baseline_sha256:
        raise ValueError(f"bat {bat.serial!r}: stored baseline {bat.baseline_name} fails its "
                         "SHA-256 checksum (registry tampered with or damaged)")
    return content


def list_bats(conn: sqlite3.Connection) -> list[BatSummary]:
    """All bats by serial, with their inspection count and latest decision."""
    rows = conn.execute("""
        SELECT b.serial, b.species, b.registered_at, count(i.id), max(i.inspected_at),
               (SELECT altered FROM inspections j WHERE j.serial = b.serial
                ORDER BY j.inspected_at DESC, j.id DESC LIMIT 1)
        FROM bats b LEFT JOIN inspections i ON i.serial = b.serial
        GROUP BY b.serial ORDER BY b.serial
    """).fetchall()
    return [BatSummary(r[0], r[1], r[2], int(r[3]), r[4], None if r[5] is None else bool(r[5]))
            for r in rows]


def add_inspection(
    conn: sqlite3.Connection, serial: str, verdict: dict, retest_name: str, retest_sha256: str,
    baseline_sha256: str, report_path: str | None = None,
) -> Inspection:
    """Store one inspection of a registered bat (``verdict`` holds at least ``altered``)."""
    stamp = now_utc()
    with transaction(conn):
        if not conn.execute("SELECT 1 FROM bats WHERE serial = ?", (serial,)).fetchone():
            raise ValueError(f"unknown serial {serial!r}: no such bat in the registry")
        cur = conn.execute(
            "INSERT INTO inspections (serial, altered, verdict_json, retest_name, retest_sha256, "
            "baseline_sha256, report_path, inspected_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
            (serial, int(bool(verdict["altered"])), json.dumps(verdict), retest_name,
             retest_sha256, baseline_sha256, report_path, stamp))
        new_id = int(cur.lastrowid)
    return Inspection(new_id, serial, bool(verdict["altered"]), verdict, retest_name,
                      retest_sha256, baseline_sha256, report_path, stamp)


def history(conn: sqlite3.Connection, serial: str) -> list[Inspection]:
    """The bat's inspections, oldest first; ValueError if the serial is unknown."""
    if not conn.execute("SELECT 1 FROM bats WHERE serial = ?", (serial,)).fetchone():
        raise ValueError(f"unknown serial {serial!r}: no such bat in the registry")
    rows = conn.execute(
        "SELECT id, serial, altered, verdict_json, retest_name, retest_sha256, baseline_sha256, "
        "report_path, inspected_at FROM inspections WHERE serial = ? "
        "ORDER BY inspected_at, id", (serial,)).fetchall()
    return [Inspection(r[0], r[1], bool(r[2]), json.loads(r[3]), r[4], r[5], r[6], r[7], r[8])
            for r in rows]
