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
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from batlab import custody, signing
from batlab.formatting import status_of

BUSY_TIMEOUT_S = 60.0


def default_db_path(env: dict | None = None) -> Path:
    """Return the registry's path.

    ``$BATLAB_DB``, else ``$XDG_DATA_HOME/batlab/registry.sqlite``, else
    ``~/.local/share/batlab/registry.sqlite``.
    """
    env = os.environ if env is None else env
    if env.get("BATLAB_DB"):
        return Path(env["BATLAB_DB"]).expanduser()
    base = env.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base).expanduser() / "batlab" / "registry.sqlite"


def sha256_bytes(data: bytes) -> str:
    """Return the hex SHA-256 of ``data``."""
    return hashlib.sha256(data).hexdigest()


def now_utc() -> str:
    """ISO 8601 UTC time stamp with microseconds (sorts as text)."""
    return datetime.now(timezone.utc).isoformat(timespec="microseconds")


# ---------------------------------------------------------------------------------------------
# Schema and migrations


def _script(conn: sqlite3.Connection, sql: str) -> None:
    """Run ``;``-separated statements inside the current transaction.

    ``executescript`` would commit it.
    """
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
    """Migrate to version 2.

    Profile stations in their own table, species column, baseline files stored
    once by checksum, inspections record the baseline they were judged against, the verdict's
    decision as a column, the re-test's file name and the report written.
    """
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


_canonical = custody.canonical


def _migrate_3(conn: sqlite3.Connection) -> None:
    """Migrate to version 3.

    Every judged file kept (``baseline_files`` becomes ``files``: re-tests too),
    inspections name the reference record they were judged against, their report inputs and
    their status, and the hash-chained custody log (``custody``) covering every stored file,
    reference and verdict. Existing content is chained in the order files, bats, inspections;
    an inspection made before version 3 has no re-test file and no reference record.
    """
    _script(conn, """
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
    for sha, name in conn.execute("SELECT sha256, name FROM files ORDER BY rowid").fetchall():
        _append_legacy_record(conn, "file", sha, sha, _canonical({"name": name}))
    for (serial,) in conn.execute("SELECT serial FROM bats ORDER BY serial").fetchall():
        _append_legacy_record(conn, "reference", serial, None,
                              _canonical(_bat_payload(conn, serial)))
    for row in conn.execute("SELECT id, verdict_json FROM inspections ORDER BY id").fetchall():
        conn.execute("UPDATE inspections SET status = ? WHERE id = ?",
                     (status_of(json.loads(row[1])), row[0]))
        seq = _append_legacy_record(conn, "verdict", str(row[0]), None,
                                    _canonical(_inspection_payload(conn, row[0])))
        conn.execute("UPDATE inspections SET record_seq = ? WHERE id = ?", (seq, row[0]))


def _migrate_4(conn: sqlite3.Connection) -> None:
    """Migrate to version 4.

    Signed custody records (``signer``, ``signature``; a ``seal`` kind) and no
    ``inspections.altered`` (written, never read: ``status`` says it). Existing records stay
    unsigned legacy records; when there are any, a signed seal record naming how many follows
    them, so they cannot be extended or stripped later without the lab's key.
    """
    _script(conn, """
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
    n = conn.execute("SELECT count(*) FROM custody").fetchone()[0]
    if n:
        _append_record(conn, "seal", "legacy", None, _canonical({"legacy_records": n}))


MIGRATIONS: dict[int, Callable[[sqlite3.Connection], None]] = {
    1: _migrate_1, 2: _migrate_2, 3: _migrate_3, 4: _migrate_4}
SCHEMA_VERSION = max(MIGRATIONS)


def schema_version(conn: sqlite3.Connection) -> int:
    """Return the database's schema version (0 for an empty database)."""
    has = conn.execute(
        "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'schema_version'").fetchone()
    if not has:
        return 0
    row = conn.execute("SELECT max(version) FROM schema_version").fetchone()
    return int(row[0] or 0)


def _foreign_tables(conn: sqlite3.Connection) -> list[str]:
    """Tables of a database without a batlab schema (empty for a new or batlab database)."""
    if schema_version(conn):
        return []
    return [r[0] for r in conn.execute(
        "SELECT name FROM sqlite_master WHERE type IN ('table', 'view') AND name NOT LIKE "
        "'sqlite_%' AND name != 'schema_version' ORDER BY name")]


def _refuse_foreign(conn: sqlite3.Connection, path: object = "database") -> None:
    """ValueError when the database holds tables of its own and no batlab schema."""
    tables = _foreign_tables(conn)
    if tables:
        raise ValueError(f"{path}: not a batlab registry (it has tables of its own: "
                         f"{', '.join(tables[:5])}); left untouched")


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
                _refuse_foreign(conn)
                conn.execute("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER "
                             "NOT NULL, applied_at TEXT NOT NULL)")
            MIGRATIONS[version + 1](conn)
            conn.execute("INSERT INTO schema_version (version, applied_at) VALUES (?, ?)",
                         (version + 1, now_utc()))


# ---------------------------------------------------------------------------------------------
# Connections and transactions


def _writable(path: Path) -> bool:
    """Whether this process can write the registry file and its directory (WAL needs both)."""
    return os.access(path, os.W_OK) and os.access(path.parent, os.W_OK)


def _enable_wal(conn: sqlite3.Connection, deadline_s: float = BUSY_TIMEOUT_S) -> None:
    """``PRAGMA journal_mode = WAL``, retried while another process holds the file.

    Switching a file to WAL upgrades a shared lock to an exclusive one; while another
    connection holds the reserved lock (a second process creating the same registry) that
    upgrade could deadlock, so SQLite answers "database is locked" at once, without its busy
    handler (1 run in 30 of four processes creating one registry under load). The mode is
    stored in the file, so the retry usually finds it already set.
    """
    stop = time.monotonic() + deadline_s
    pause_s = 0.005
    while True:
        try:
            conn.execute("PRAGMA journal_mode = WAL")
            return
        except sqlite3.OperationalError as exc:
            if "locked" not in str(exc) or time.monotonic() > stop:
                raise
        time.sleep(pause_s)
        pause_s = min(2 * pause_s, 0.2)


def connect(
    path: str | os.PathLike, target: int = SCHEMA_VERSION, create: bool = True,
    readonly: bool = False,
) -> sqlite3.Connection:
    """Open the registry at ``path`` (creating it if ``create``) and migrate it to ``target``.

    ``readonly`` (or a file this process may not write) opens it read-only: nothing is
    written (an older schema is migrated only when the file is writable, else refused with a
    message saying what to do). A database with tables of its own and no batlab schema is
    refused and left untouched. Every failure is a ValueError naming the file.
    """
    path = Path(path)
    if path.exists() and path.is_dir():
        raise ValueError(f"{path}: registry path is a directory")
    if not create and not path.exists():
        raise ValueError(f"{path}: no registry there (register a bat first, or give --db)")
    if path.exists() and not os.access(path, os.R_OK):
        raise ValueError(f"{path}: registry not readable (permission denied)")
    if path.exists() and path.stat().st_size:
        _refuse_foreign_file(path)
    if readonly or (path.exists() and not _writable(path)):
        conn = _connect_readonly(path, migratable=_writable(path))
        if conn is not None:
            return conn
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{path}: cannot create the registry's directory ({exc.strerror})") \
            from None
    try:
        conn = sqlite3.connect(path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        conn.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
        _enable_wal(conn)
        conn.execute("PRAGMA synchronous = FULL")
        conn.execute("PRAGMA foreign_keys = ON")
        migrate(conn, target)
    except sqlite3.DatabaseError as exc:
        raise ValueError(f"{path}: not a usable batlab registry ({exc})") from None
    return conn


def _refuse_foreign_file(path: Path) -> None:
    """Look at an existing file without changing it.

    ValueError if it holds tables of its own and no batlab schema. A file SQLite cannot read
    here (not a database, or one being created by another process) is left to the normal opening
    to judge.
    """
    try:
        probe = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro&immutable=1", uri=True)
    except sqlite3.DatabaseError:
        return
    try:
        _refuse_foreign(probe, path)
    except sqlite3.DatabaseError:
        return
    finally:
        probe.close()


class _ReadOnlyConnection(sqlite3.Connection):
    """A read-only connection that removes the ``-wal``/``-shm`` files its opening created.

    Left behind, they are this user's and lock the owner out.
    """

    created: tuple[Path, ...] = ()

    def close(self) -> None:
        super().close()
        for leftover in self.created:
            if leftover.name.endswith("-shm") or (leftover.exists()
                                                  and leftover.stat().st_size == 0):
                leftover.unlink(missing_ok=True)


def _connect_readonly(path: Path, migratable: bool = False) -> sqlite3.Connection | None:
    """Open a read-only connection that leaves nothing behind and never reads stale data.

    With no write-ahead log content the file is opened ``immutable=1`` (no ``-shm`` needed,
    none created); with WAL content ``mode=ro`` reads it through the ``-shm`` index and the
    files that created are removed on close; where that index cannot be made the registry is
    refused rather than read without its log. Returns None for an older schema when
    ``migratable`` (the caller then opens it for writing and migrates it).
    """
    wal, shm = Path(f"{path}-wal"), Path(f"{path}-shm")
    before = {p for p in (wal, shm) if p.exists()}
    live_log = wal.exists() and wal.stat().st_size > 0
    flags = "mode=ro" if live_log else "mode=ro&immutable=1"
    try:
        conn = sqlite3.connect(f"{path.resolve().as_uri()}?{flags}", uri=True,
                               timeout=BUSY_TIMEOUT_S, isolation_level=None,
                               factory=_ReadOnlyConnection)
        version = schema_version(conn)
        conn.created = tuple(p for p in (wal, shm) if p not in before)
    except sqlite3.DatabaseError as exc:
        if live_log:
            raise ValueError(f"{path}: its write-ahead log {wal.name} cannot be read here "
                             f"without its index ({exc}); open the registry once with write "
                             "access (reading the file alone would show stale data)") from None
        raise ValueError(f"{path}: not a usable batlab registry ({exc})") from None
    if version == SCHEMA_VERSION:
        return conn
    conn.close()
    if 0 < version < SCHEMA_VERSION and migratable:
        return None
    raise ValueError(f"{path}: read-only registry at schema version {version}, this batlab "
                     f"reads {SCHEMA_VERSION} (open it once with write access to migrate)")


@contextmanager
def transaction(conn: sqlite3.Connection) -> Iterator[sqlite3.Connection]:
    """Run the block in ``BEGIN IMMEDIATE`` ... ``COMMIT``.

    Rolled back on any exception (or never committed if the process dies). A read-only
    registry is a one-line ValueError.
    """
    try:
        conn.execute("BEGIN IMMEDIATE")
        try:
            yield conn
        except BaseException:
            conn.execute("ROLLBACK")
            raise
        conn.execute("COMMIT")
    except sqlite3.OperationalError as exc:
        if "readonly" in str(exc) or "read-only" in str(exc):
            raise ValueError(f"registry is read-only ({exc}): nothing can be stored in it") \
                from None
        raise


@contextmanager
def open_registry(
    path: str | os.PathLike, create: bool = True, readonly: bool = False,
) -> Iterator[sqlite3.Connection]:
    """``connect`` as a context manager that closes the connection."""
    conn = connect(path, create=create, readonly=readonly)
    try:
        yield conn
    finally:
        conn.close()


# ---------------------------------------------------------------------------------------------
# The custody chain (record format, signatures and the chain's own check: batlab/custody.py)

GENESIS_SHA256 = custody.GENESIS_SHA256
record_hash = custody.legacy_record_hash
_KEYS: dict[str, object] = {}


def _lab_key():
    """Return the lab's signing key (created on first write), loaded once per key file."""
    path = str(signing.key_path())
    if path not in _KEYS:
        _KEYS[path] = signing.signing_key(create=True)
    return _KEYS[path]


def _last_record(conn: sqlite3.Connection) -> tuple[int, str]:
    last = conn.execute("SELECT seq, record_sha256 FROM custody ORDER BY seq DESC LIMIT 1"
                        ).fetchone()
    return (0, GENESIS_SHA256) if last is None else (int(last[0]), last[1])


def _append_legacy_record(conn: sqlite3.Connection, kind: str, subject: str,
                          content_sha256: str | None, payload: str | None) -> int:
    """Append an unsigned schema-3 record (migration 3 only); returns its sequence number."""
    if content_sha256 is None:
        content_sha256 = sha256_bytes(payload.encode("utf-8"))
    seq, prev = _last_record(conn)
    seq += 1
    stamp = now_utc()
    conn.execute("INSERT INTO custody (seq, kind, subject, payload, content_sha256, prev_sha256, "
                 "record_sha256, recorded_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                 (seq, kind, subject, payload, content_sha256, prev,
                  record_hash(seq, kind, subject, content_sha256, prev, stamp), stamp))
    return seq


def _append_record(conn: sqlite3.Connection, kind: str, subject: str,
                   content_sha256: str | None, payload: str | None) -> int:
    """Append a signed custody record (inside the caller's transaction).

    ``content_sha256`` defaults to the hash of ``payload``; returns the record's number.
    """
    if content_sha256 is None:
        content_sha256 = sha256_bytes(payload.encode("utf-8"))
    key = _lab_key()
    signer = signing.key_id(key.public_key())
    seq, prev = _last_record(conn)
    seq += 1
    stamp = now_utc()
    data = custody.record_bytes(seq, kind, subject, content_sha256, prev, stamp, signer)
    conn.execute("INSERT INTO custody (seq, kind, subject, payload, content_sha256, prev_sha256, "
                 "record_sha256, recorded_at, signer, signature) "
                 "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                 (seq, kind, subject, payload, content_sha256, prev, sha256_bytes(data), stamp,
                  signer, signing.sign(key, data)))
    return seq


def _bat_payload(conn: sqlite3.Connection, serial: str) -> dict:
    """Return what a reference record holds: the bat's row and profile as stored now."""
    row = conn.execute("SELECT serial, species, meta_json, reference_json, modes_json, "
                       "baseline_sha256, registered_at FROM bats WHERE serial = ?",
                       (serial,)).fetchone()
    stations = conn.execute("SELECT x_m, diameter_m FROM stations WHERE serial = ? ORDER BY idx",
                            (serial,)).fetchall()
    name = conn.execute("SELECT name FROM files WHERE sha256 = ?", (row[5],)).fetchone()
    return {"serial": row[0], "species": row[1], "meta": json.loads(row[2]),
            "reference": json.loads(row[3]), "modes": json.loads(row[4]),
            "baseline_sha256": row[5], "baseline_name": name[0] if name else "",
            "registered_at": row[6], "profile_x_m": [s[0] for s in stations],
            "profile_diameter_m": [s[1] for s in stations]}


def _inspection_payload(conn: sqlite3.Connection, inspection_id: int) -> dict:
    """Return what a verdict record holds: the inspection's row as stored now.

    All but ``report_path`` (a note of where a copy of the report was written) and
    ``record_seq``.
    """
    row = conn.execute("SELECT id, serial, status, verdict_json, retest_name, retest_sha256, "
                       "baseline_sha256, reference_seq, inputs_json, inspected_at "
                       "FROM inspections WHERE id = ?", (inspection_id,)).fetchone()
    return {"id": row[0], "serial": row[1], "status": row[2], "verdict": json.loads(row[3]),
            "retest_name": row[4], "retest_sha256": row[5], "baseline_sha256": row[6],
            "reference_seq": row[7], "inputs": None if row[8] is None else json.loads(row[8]),
            "inspected_at": row[9]}


@dataclass(frozen=True)
class CustodyRecord:
    """A custody record's identity: number, kind, subject, hashes, time and signer."""

    seq: int
    kind: str
    subject: str
    content_sha256: str
    prev_sha256: str
    record_sha256: str
    recorded_at: str
    signer: str | None = None


def custody_record(conn: sqlite3.Connection, seq: int) -> CustodyRecord:
    """Return custody record ``seq``; ValueError if it is not in the registry."""
    row = conn.execute("SELECT seq, kind, subject, content_sha256, prev_sha256, record_sha256, "
                       "recorded_at, signer FROM custody WHERE seq = ?", (seq,)).fetchone()
    if row is None:
        raise ValueError(f"custody record #{seq} not in the registry")
    return CustodyRecord(*row)


def chain_head(conn: sqlite3.Connection) -> CustodyRecord | None:
    """Return the last custody record (its hash seals everything before it)."""
    row = conn.execute("SELECT max(seq) FROM custody").fetchone()
    return None if row[0] is None else custody_record(conn, int(row[0]))


def head(conn: sqlite3.Connection) -> str | None:
    """Return the head of the chain as ``SEQ:SHA256`` (None for an empty registry)."""
    last = chain_head(conn)
    return None if last is None else custody.head_text(last.seq, last.record_sha256)


def custody_rows(conn: sqlite3.Connection) -> list[custody.Row]:
    """Return every custody record, in sequence order."""
    return [custody.Row(*r) for r in conn.execute(
        "SELECT seq, kind, subject, payload, content_sha256, prev_sha256, record_sha256, "
        "recorded_at, signer, signature FROM custody ORDER BY seq")]


@dataclass(frozen=True)
class CheckResult:
    """The result of ``registry check``.

    ``problems`` is empty when the registry is intact; ``first_changed`` is the first custody
    record that no longer verifies (None if none); ``head`` the chain's head as ``SEQ:SHA256``.
    """

    n_records: int
    n_files: int
    problems: list[str]
    notes: list[str]
    first_changed: int | None
    head_sha256: str | None
    head: str | None = None

    @property
    def ok(self) -> bool:
        """Whether nothing is wrong."""
        return not self.problems


def check(conn: sqlite3.Connection, trusted: set[str] | None = None,
          head_seen: str | None = None) -> CheckResult:
    """Verify the registry.

    SQLite's integrity and foreign keys, every stored file against its
    SHA-256, every file an inspection or bat names is present, the custody chain (each
    record's hash, link, content hash and signature by a trusted key: ``trusted``, default
    the lab's own key), coverage (every bat, file and inspection row has its one custody
    record, every record's row exists) and, with ``head_seen`` (``SEQ:SHA256`` noted
    earlier), that the chain still holds that record. Names the first changed record; a
    registry too damaged to read is one problem naming SQLite's complaint.
    """
    if trusted is None:
        trusted = signing.trusted_keys()
    if head_seen is not None:
        custody.parse_head(head_seen)
    try:
        return _check(conn, trusted, head_seen)
    except sqlite3.DatabaseError as exc:
        try:
            integrity = "; ".join(r[0] for r in conn.execute("PRAGMA integrity_check")
                                  .fetchall()[:3])
        except sqlite3.DatabaseError:
            integrity = "integrity check failed too"
        return CheckResult(0, 0, [f"registry damaged, unreadable ({exc}): {integrity}"], [],
                           None, None)


def _check_files(conn: sqlite3.Connection, problems: list[str], notes: list[str]) -> dict:
    """Check SQLite's integrity, foreign keys and every stored file; returns sha -> name."""
    integrity = conn.execute("PRAGMA integrity_check").fetchall()
    if [r[0] for r in integrity] != ["ok"]:
        problems.append("SQLite integrity check: " + "; ".join(r[0] for r in integrity[:3]))
    if conn.execute("PRAGMA foreign_key_check").fetchall():
        problems.append("foreign keys: rows refer to missing rows")
    files = {}
    for sha, name, content in conn.execute("SELECT sha256, name, content FROM files"):
        files[sha] = name
        if sha256_bytes(bytes(content)) != sha:
            problems.append(f"file {name} ({sha[:12]}): content fails its SHA-256")
    for serial, sha in conn.execute("SELECT serial, baseline_sha256 FROM bats"):
        if sha not in files:
            problems.append(f"bat {serial!r}: baseline file {sha[:12]} missing")
    for iid, sha, bsha, ref in conn.execute(
            "SELECT id, retest_sha256, baseline_sha256, reference_seq FROM inspections"):
        if sha not in files:
            if ref is None:
                notes.append(f"inspection #{iid}: re-test file not kept (inspected before "
                             "schema 3)")
            else:
                problems.append(f"inspection #{iid}: re-test file {sha[:12]} missing")
        if bsha not in files:
            problems.append(f"inspection #{iid}: baseline file {bsha[:12]} missing")
    return files


def _by_subject(rows: list[custody.Row], kind: str) -> dict[str, list[custody.Row]]:
    out: dict[str, list[custody.Row]] = {}
    for r in rows:
        if r.kind == kind:
            out.setdefault(r.subject, []).append(r)
    return out


def _check_coverage(conn: sqlite3.Connection, rows: list[custody.Row], files: dict,
                    problems: list[str]) -> list[int]:
    """Check that every row has its custody record and every record its row.

    One record per file and verdict, the latest registration for a bat, each matching its row;
    returns the numbers of the records whose row was changed.
    """
    changed = []
    for sha, recs in _by_subject(rows, "file").items():
        if sha not in files:
            problems.append(f"custody record #{recs[0].seq}: file {sha[:12]} missing from the "
                            "registry (row deleted)")
        if len(recs) > 1:
            problems.append(f"file {sha[:12]}: {len(recs)} custody records "
                            f"(#{', #'.join(str(r.seq) for r in recs)}), expected one")
    file_recs = {r.subject for r in rows if r.kind == "file"}
    problems += [f"file {files[sha]} ({sha[:12]}): no custody record" for sha in files
                 if sha not in file_recs]
    refs = _by_subject(rows, "reference")
    bats = {s for (s,) in conn.execute("SELECT serial FROM bats")}
    for serial in sorted(bats):
        if serial not in refs:
            problems.append(f"bat {serial!r}: no custody record")
        elif _canonical(_bat_payload(conn, serial)) != refs[serial][-1].payload:
            problems.append(f"bat {serial!r}: stored bat differs from custody record "
                            f"#{refs[serial][-1].seq}")
            changed.append(refs[serial][-1].seq)
    problems += [f"custody record #{recs[0].seq}: bat {s!r} is no longer in the registry "
                 "(row deleted)" for s, recs in refs.items() if s not in bats]
    changed += _check_verdicts(conn, _by_subject(rows, "verdict"), problems)
    return changed


def _check_verdicts(conn: sqlite3.Connection, verdicts: dict[str, list[custody.Row]],
                    problems: list[str]) -> list[int]:
    """Each inspection row against its one verdict record (and its ``record_seq``)."""
    changed = []
    rows = dict(conn.execute("SELECT id, record_seq FROM inspections").fetchall())
    for iid in sorted(rows):
        recs = verdicts.get(str(iid))
        if recs is None:
            problems.append(f"inspection #{iid}: no custody record")
            continue
        if len(recs) > 1:
            problems.append(f"inspection #{iid}: {len(recs)} verdict records "
                            f"(#{', #'.join(str(r.seq) for r in recs)}), expected one")
        if rows[iid] != recs[0].seq:
            problems.append(f"inspection #{iid}: names verdict record #{rows[iid]}, its record "
                            f"is #{recs[0].seq}")
        if _canonical(_inspection_payload(conn, iid)) != recs[0].payload:
            problems.append(f"inspection #{iid}: stored verdict differs from custody record "
                            f"#{recs[0].seq}")
            changed.append(recs[0].seq)
    problems += [f"custody record #{recs[0].seq}: inspection #{s} is no longer in the "
                 "registry (rows deleted)" for s, recs in verdicts.items()
                 if not s.isdigit() or int(s) not in rows]
    return changed


def _check(conn: sqlite3.Connection, trusted: set[str], head_seen: str | None) -> CheckResult:
    problems: list[str] = []
    notes: list[str] = []
    files = _check_files(conn, problems, notes)
    rows = custody_rows(conn)
    chain = custody.check_chain(rows, trusted)
    problems += chain.problems
    notes += chain.notes
    changed = _check_coverage(conn, rows, files, problems)
    if head_seen is not None:
        problems += custody.check_head(rows, head_seen)
    first = min([s for s in (chain.first_changed, *changed) if s is not None], default=None)
    last = rows[-1] if rows else None
    return CheckResult(len(rows), len(files), problems, notes, first,
                       None if last is None else last.record_sha256,
                       None if last is None else custody.head_text(last.seq,
                                                                   last.record_sha256))

# ---------------------------------------------------------------------------------------------
# Records


@dataclass(frozen=True)
class BatRecord:
    """A registered bat, SI, in plain data (the pipeline turns it into model objects).

    Attributes
    ----------
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
        reference_seq: the custody record of this registration (0 before it is stored).
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
    reference_seq: int = 0


@dataclass(frozen=True)
class BatSummary:
    """One line of ``batlab bats``: a bat, its inspection count and latest decision."""

    serial: str
    species: str
    registered_at: str
    n_inspections: int
    last_inspected_at: str | None
    last_altered: bool | None
    last_status: str | None = None


@dataclass(frozen=True)
class Inspection:
    """A stored inspection.

    ``altered`` is None when the verdict was inconclusive;
    ``reference_seq`` the custody record of the registration it was judged against (None
    before schema 3); ``record_seq``/``record_sha256`` its own custody record.
    """

    id: int
    serial: str
    altered: bool | None
    status: str
    verdict: dict
    retest_name: str
    retest_sha256: str
    baseline_sha256: str
    report_path: str | None
    inspected_at: str
    reference_seq: int | None = None
    inputs: dict | None = None
    record_seq: int | None = None
    record_sha256: str | None = None


def encode_modes(m) -> dict:
    """Return fitted modes as the registry stores them (``modes_json``): plain lists, SI.

    ``m`` is an ``updating.correlate.measured.MeasuredModes``.
    """
    import numpy as np

    return {"freq_hz": np.asarray(m.freq_hz).tolist(),
            "damping_ratio": np.asarray(m.damping_ratio).tolist(),
            "shapes": np.asarray(m.shapes).tolist(), "x_m": np.asarray(m.x_m).tolist(),
            "sensor_x_m": float(m.sensor_x_m),
            "freq_std_hz": None if m.freq_std_hz is None else np.asarray(m.freq_std_hz).tolist()}


def decode_modes(d: dict):
    """Return the stored modes as ``MeasuredModes`` (shapes points x modes)."""
    import numpy as np

    from updating.correlate.measured import MeasuredModes

    std = d.get("freq_std_hz")
    return MeasuredModes(np.asarray(d["freq_hz"], float),
                         np.asarray(d["shapes"], float).reshape(len(d["x_m"]), -1),
                         np.asarray(d["x_m"], float), np.asarray(d["damping_ratio"], float),
                         float(d["sensor_x_m"]), None if std is None else np.asarray(std, float))


def has_file(conn: sqlite3.Connection, sha256: str) -> bool:
    """Return whether a file with this SHA-256 is stored."""
    return conn.execute("SELECT 1 FROM files WHERE sha256 = ?", (sha256,)).fetchone() is not None


def has_bat(conn: sqlite3.Connection, serial: str) -> bool:
    """Return whether the serial is registered."""
    return conn.execute("SELECT 1 FROM bats WHERE serial = ?", (serial,)).fetchone() is not None


def store_file(conn: sqlite3.Connection, name: str, content: bytes) -> str:
    """Keep a test file (inside the caller's transaction), once per content.

    A new file gets a custody record; returns its SHA-256.
    """
    digest = sha256_bytes(content)
    cur = conn.execute("INSERT OR IGNORE INTO files (sha256, name, size, content) "
                       "VALUES (?, ?, ?, ?)", (digest, name, len(content), content))
    if cur.rowcount:
        _append_record(conn, "file", digest, digest, _canonical({"name": name}))
    return digest


def add_bat(
    conn: sqlite3.Connection, bat: BatRecord, baseline_name: str, baseline: bytes,
    replace: bool = False,
) -> BatRecord:
    """Store a bat with a copy of its baseline file.

    ValueError if the serial exists and not ``replace``. Replacing keeps the bat's inspections,
    each naming the registration (custody record) it was judged against, and every file ever
    stored.
    """
    if not bat.serial.strip():
        raise ValueError("serial number is empty")
    stamp = now_utc()
    with transaction(conn):
        exists = has_bat(conn, bat.serial)
        if exists and not replace:
            raise ValueError(f"bat {bat.serial!r} is already registered (use --replace)")
        digest = store_file(conn, baseline_name, baseline)
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
        payload = _bat_payload(conn, bat.serial)
        _append_record(conn, "reference", bat.serial, None, _canonical(payload))
    return get_bat(conn, bat.serial)


def _bat_from_payload(p: dict, seq: int) -> BatRecord:
    return BatRecord(
        serial=p["serial"], profile_x_m=p["profile_x_m"],
        profile_diameter_m=p["profile_diameter_m"], meta=p["meta"], species=p["species"],
        reference=p["reference"], modes=p["modes"], baseline_name=p["baseline_name"],
        baseline_sha256=p["baseline_sha256"], registered_at=p["registered_at"],
        reference_seq=seq)


def get_bat(conn: sqlite3.Connection, serial: str) -> BatRecord:
    """Return the registered bat as it is now; ValueError naming the serial if unknown."""
    if not has_bat(conn, serial):
        raise ValueError(f"unknown serial {serial!r}: no such bat in the registry")
    seq = conn.execute("SELECT max(seq) FROM custody WHERE kind = 'reference' AND subject = ?",
                       (serial,)).fetchone()[0]
    return _bat_from_payload(_bat_payload(conn, serial), int(seq or 0))


def bat_as_registered(conn: sqlite3.Connection, reference_seq: int) -> BatRecord:
    """Return the bat as registration record ``reference_seq`` stored it.

    After a ``--replace`` the bat's current row differs; this is what an earlier inspection was
    judged against. The record's content is checked against its hash.
    """
    row = conn.execute("SELECT payload, content_sha256 FROM custody WHERE seq = ? AND "
                       "kind = 'reference'", (reference_seq,)).fetchone()
    if row is None:
        raise ValueError(f"registration record #{reference_seq} not in the registry")
    if sha256_bytes(row[0].encode("utf-8")) != row[1]:
        raise ValueError(f"registration record #{reference_seq} fails its SHA-256 checksum "
                         "(registry tampered with or damaged; run `batlab registry check`)")
    return _bat_from_payload(json.loads(row[0]), reference_seq)


def stored_file(conn: sqlite3.Connection, sha256: str, what: str) -> tuple[str, bytes]:
    """Return (name, bytes) of a stored file after checking its SHA-256.

    ValueError naming ``what`` when it is missing or changed.
    """
    row = conn.execute("SELECT name, content FROM files WHERE sha256 = ?", (sha256,)).fetchone()
    if row is None:
        raise ValueError(f"{what}: file {sha256[:12]} missing from the registry")
    content = bytes(row[1])
    if sha256_bytes(content) != sha256:
        raise ValueError(f"{what}: stored {row[0]} fails its SHA-256 checksum (registry "
                         "tampered with or damaged)")
    return row[0], content


def baseline_file(conn: sqlite3.Connection, bat: BatRecord) -> bytes:
    """Return the stored baseline file of ``bat`` after checking its SHA-256."""
    return stored_file(conn, bat.baseline_sha256, f"bat {bat.serial!r} baseline")[1]


def list_bats(conn: sqlite3.Connection) -> list[BatSummary]:
    """All bats by serial, with their inspection count and latest decision."""
    rows = conn.execute("""
        SELECT b.serial, b.species, b.registered_at, count(i.id), max(i.inspected_at),
               (SELECT status FROM inspections j WHERE j.serial = b.serial
                ORDER BY j.inspected_at DESC, j.id DESC LIMIT 1)
        FROM bats b LEFT JOIN inspections i ON i.serial = b.serial
        GROUP BY b.serial ORDER BY b.serial
    """).fetchall()
    return [BatSummary(r[0], r[1], r[2], int(r[3]), r[4],
                       None if r[5] in (None, "inconclusive") else r[5] == "altered", r[5])
            for r in rows]


def add_inspection(
    conn: sqlite3.Connection, serial: str, verdict: dict, retest_name: str, retest: bytes,
    reference_seq: int | None = None, inputs: dict | None = None,
    report_path: str | None = None,
) -> Inspection:
    """Store one inspection of a registered bat.

    With its re-test file, the registration (custody record ``reference_seq``, default: the
    bat's current one) it was judged against and the report's other inputs; appends its verdict
    record to the custody chain. ``verdict`` holds ``status`` or ``altered``.
    """
    stamp = now_utc()
    with transaction(conn):
        if not has_bat(conn, serial):
            raise ValueError(f"unknown serial {serial!r}: no such bat in the registry")
        if reference_seq is None:
            reference_seq = get_bat(conn, serial).reference_seq
        ref = bat_as_registered(conn, reference_seq)
        if ref.serial != serial:
            raise ValueError(f"registration record #{reference_seq} is of bat {ref.serial!r}, "
                             f"not {serial!r}")
        digest = store_file(conn, retest_name, retest)
        status = status_of(verdict)
        cur = conn.execute(
            "INSERT INTO inspections (serial, status, verdict_json, retest_name, "
            "retest_sha256, baseline_sha256, reference_seq, inputs_json, report_path, "
            "inspected_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (serial, status, json.dumps(verdict), retest_name, digest,
             ref.baseline_sha256, reference_seq, None if inputs is None else json.dumps(inputs),
             report_path, stamp))
        new_id = int(cur.lastrowid)
        seq = _append_record(conn, "verdict", str(new_id), None,
                             _canonical(_inspection_payload(conn, new_id)))
        conn.execute("UPDATE inspections SET record_seq = ? WHERE id = ?", (seq, new_id))
    return get_inspection(conn, new_id)


def set_report_path(conn: sqlite3.Connection, inspection_id: int, report_path: str) -> None:
    """Note where the inspection's report was written (not part of its custody record)."""
    with transaction(conn):
        conn.execute("UPDATE inspections SET report_path = ? WHERE id = ?",
                     (report_path, inspection_id))


_INSPECTION_COLUMNS = ("i.id, i.serial, i.status, i.verdict_json, i.retest_name, "
                       "i.retest_sha256, i.baseline_sha256, i.report_path, i.inspected_at, "
                       "i.reference_seq, i.inputs_json, i.record_seq, c.record_sha256")


def _inspection(r) -> Inspection:
    status = r[2] or status_of(json.loads(r[3]))
    altered = None if status == "inconclusive" else status == "altered"
    return Inspection(r[0], r[1], altered, status, json.loads(r[3]), r[4], r[5], r[6], r[7],
                      r[8], r[9], None if r[10] is None else json.loads(r[10]), r[11], r[12])


def get_inspection(conn: sqlite3.Connection, inspection_id: int) -> Inspection:
    """Return stored inspection ``inspection_id``; ValueError if there is none."""
    row = conn.execute(f"SELECT {_INSPECTION_COLUMNS} FROM inspections i LEFT JOIN custody c "
                       "ON c.seq = i.record_seq WHERE i.id = ?", (inspection_id,)).fetchone()
    if row is None:
        raise ValueError(f"no inspection #{inspection_id} in the registry")
    return _inspection(row)


def history(conn: sqlite3.Connection, serial: str) -> list[Inspection]:
    """Return the bat's inspections, oldest first; ValueError if the serial is unknown."""
    if not has_bat(conn, serial):
        raise ValueError(f"unknown serial {serial!r}: no such bat in the registry")
    rows = conn.execute(
        f"SELECT {_INSPECTION_COLUMNS} FROM inspections i LEFT JOIN custody c "
        "ON c.seq = i.record_seq WHERE i.serial = ? ORDER BY i.inspected_at, i.id",
        (serial,)).fetchall()
    return [_inspection(r) for r in rows]


def all_inspections(conn: sqlite3.Connection, serial: str | None = None) -> list[Inspection]:
    """Every inspection (of one bat when ``serial``), by bat then time."""
    if serial is not None:
        return history(conn, serial)
    rows = conn.execute(
        f"SELECT {_INSPECTION_COLUMNS} FROM inspections i LEFT JOIN custody c "
        "ON c.seq = i.record_seq ORDER BY i.serial, i.inspected_at, i.id").fetchall()
    return [_inspection(r) for r in rows]
