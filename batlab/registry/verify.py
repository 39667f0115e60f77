"""``registry check``: every stored file, row and custody record verified against the chain."""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass

import sqlalchemy as sa

from batlab import custody, signing
from batlab.registry.calibration_files import origin_problems
from batlab.registry.chain import (
    bat_payload,
    calibration_payload,
    canonical,
    custody_rows,
    inspection_payload,
)
from batlab.registry.common import sha256_bytes
from batlab.registry.health import storage_problems
from batlab.registry.schema import bats, calibrations, files, inspections
from batlab.registry.witness import check_witnessed


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


def check(conn: sa.Connection, trusted: set[str] | None = None,
          head_seen: str | None = None, witnessed: list[dict] | None = None) -> CheckResult:
    """Verify the registry.

    The database's integrity (``health.storage_problems``, thorough: SQLite's
    ``integrity_check``) and, on SQLite, foreign keys (a PostgreSQL server enforces them),
    every stored file against its SHA-256, every file an inspection or bat names is present,
    the custody chain (each record's hash, link, content hash and signature: by one of the
    keys ``trusted`` or a key one of them handed over to; with ``trusted`` None by any key
    not retired or revoked before it, said in a note: consistency, not who signed), every
    imported calibration's signature, coverage (every bat, file, inspection and calibration
    row has its one custody record, every record's row exists) and, with ``head_seen``
    (``SEQ:SHA256`` noted earlier), that the chain still holds that record; with
    ``witnessed`` (countersigned heads, ``registry.witness``), that the chain extends each
    and that no two of one key fork. Names the first changed record; a registry too damaged
    to read is one problem naming the database's complaint.
    """
    if head_seen is not None:
        custody.parse_head(head_seen)
    try:
        return _check(conn, trusted, head_seen, witnessed or [])
    except (sa.exc.DBAPIError, sqlite3.DatabaseError) as exc:
        reason = " ".join(str(getattr(exc, "orig", None) or exc).split())
        try:
            integrity = "; ".join(storage_problems(conn, thorough=True)[:3]) or "ok"
        except (sa.exc.DBAPIError, sqlite3.DatabaseError):
            integrity = "integrity check failed too"
        return CheckResult(0, 0, [f"registry damaged, unreadable ({reason}): {integrity}"], [],
                           None, None)


def _check(conn: sa.Connection, trusted: set[str] | None, head_seen: str | None,
           witnessed: list[dict]) -> CheckResult:
    problems: list[str] = []
    notes: list[str] = []
    files_by_sha = _check_files(conn, problems, notes)
    rows = custody_rows(conn)
    chain = custody.check_chain(rows, trusted)
    problems += chain.problems
    notes += chain.notes
    changed = _check_coverage(conn, rows, files_by_sha, problems)
    if head_seen is not None:
        problems += custody.check_head(rows, head_seen)
    problems += origin_problems(conn)
    seen = check_witnessed(rows, witnessed, trusted)
    problems += seen.problems
    notes += seen.notes
    if trusted is None and rows:
        notes.append(consistency_note(rows))
    first = min([s for s in (chain.first_changed, *changed, seen.first_changed)
                 if s is not None], default=None)
    last = rows[-1] if rows else None
    return CheckResult(len(rows), len(files_by_sha), problems, notes, first,
                       None if last is None else last.record_sha256,
                       None if last is None else custody.head_text(last.seq,
                                                                   last.record_sha256))


def _fingerprint(key: str) -> str:
    try:
        return f"fingerprint {signing.fingerprint(key)}, "
    except ValueError:  # a malformed signer: its records fail already
        return ""


def consistency_note(rows: list[custody.Row]) -> str:
    """Say that no key was trusted: the signatures were checked for consistency only."""
    who = "; ".join(f"{k} ({_fingerprint(k)}records #{a}..#{b})"
                    for k, (a, b) in custody.signers(rows).items())
    return ("no --trust given: the signatures were checked for consistency only (each "
            "verifies for the key it names, none by a retired or revoked key), not who signed; "
            f"signed by {who or 'no key'}")


def _check_files(conn: sa.Connection, problems: list[str], notes: list[str]) -> dict:
    """Check the database's integrity and every stored file; return sha -> name."""
    integrity = storage_problems(conn, thorough=True)
    if integrity:
        problems.append("integrity check: " + "; ".join(integrity[:3]))
    if conn.dialect.name == "sqlite" and conn.exec_driver_sql("PRAGMA foreign_key_check"
                                                              ).fetchall():
        problems.append("foreign keys: rows refer to missing rows")
    by_sha = {}
    for sha, name, size, content in conn.execute(sa.select(
            files.c.sha256, files.c.name, files.c.size, files.c.content)):
        by_sha[sha] = name
        if sha256_bytes(bytes(content)) != sha:
            problems.append(f"file {name} ({sha[:12]}): content fails its SHA-256")
        if size != len(content):
            problems.append(f"file {name} ({sha[:12]}): size {size} differs from its "
                            f"content's {len(content)} bytes")
    for serial, sha in conn.execute(sa.select(bats.c.serial, bats.c.baseline_sha256)):
        if sha not in by_sha:
            problems.append(f"bat {serial!r}: baseline file {sha[:12]} missing")
    i = inspections.c
    for iid, sha, bsha, ref in conn.execute(sa.select(i.id, i.retest_sha256, i.baseline_sha256,
                                                      i.reference_seq)):
        if sha not in by_sha:
            if ref is None:
                notes.append(f"inspection #{iid}: re-test file not kept (inspected before "
                             "schema 3)")
            else:
                problems.append(f"inspection #{iid}: re-test file {sha[:12]} missing")
        if bsha not in by_sha:
            problems.append(f"inspection #{iid}: baseline file {bsha[:12]} missing")
    return by_sha


def _by_subject(rows: list[custody.Row], kind: str) -> dict[str, list[custody.Row]]:
    out: dict[str, list[custody.Row]] = {}
    for r in rows:
        if r.kind == kind:
            out.setdefault(r.subject, []).append(r)
    return out


def _check_coverage(conn: sa.Connection, rows: list[custody.Row], by_sha: dict,
                    problems: list[str]) -> list[int]:
    """Check that every row has its custody record and every record its row.

    One record per file and verdict, the latest registration for a bat, each matching its row;
    returns the numbers of the records whose row was changed.
    """
    changed = []
    for sha, recs in _by_subject(rows, "file").items():
        if sha not in by_sha:
            problems.append(f"custody record #{recs[0].seq}: file {sha[:12]} missing from the "
                            "registry (row deleted)")
        if len(recs) > 1:
            problems.append(f"file {sha[:12]}: {len(recs)} custody records "
                            f"(#{', #'.join(str(r.seq) for r in recs)}), expected one")
        if sha in by_sha and not _file_row_matches(conn, recs[0]):
            problems.append(f"file {by_sha[sha]} ({sha[:12]}): stored row (name, size) "
                            f"differs from custody record #{recs[0].seq}")
            changed.append(recs[0].seq)
    file_recs = {r.subject for r in rows if r.kind == "file"}
    problems += [f"file {by_sha[sha]} ({sha[:12]}): no custody record" for sha in by_sha
                 if sha not in file_recs]
    refs = _by_subject(rows, "reference")
    serials = set(conn.execute(sa.select(bats.c.serial)).scalars())
    for serial in sorted(serials):
        if serial not in refs:
            problems.append(f"bat {serial!r}: no custody record")
        elif canonical(bat_payload(conn, serial)) != refs[serial][-1].payload:
            problems.append(f"bat {serial!r}: stored bat differs from custody record "
                            f"#{refs[serial][-1].seq}")
            changed.append(refs[serial][-1].seq)
    problems += [f"custody record #{recs[0].seq}: bat {s!r} is no longer in the registry "
                 "(row deleted)" for s, recs in refs.items() if s not in serials]
    changed += _check_stored(conn, inspections, "inspection", "verdict",
                             inspection_payload, _by_subject(rows, "verdict"), problems)
    changed += _check_stored(conn, calibrations, "calibration", "calibration",
                             calibration_payload, _by_subject(rows, "calibration"), problems)
    return changed


def _file_row_matches(conn: sa.Connection, rec: custody.Row) -> bool:
    """Return whether a stored file's row equals its record: name, size and SHA-256.

    A record of the first format (``custody.name_only_file_record``) holds the name alone.
    """
    name, size = conn.execute(sa.select(files.c.name, files.c.size)
                              .where(files.c.sha256 == rec.subject)).one()
    if custody.name_only_file_record(rec):
        return rec.payload == canonical({"name": name})
    return rec.payload == custody.file_payload(name, size, rec.subject)


def _check_stored(conn: sa.Connection, table: sa.Table, noun: str, kind: str, payload,
                  records: dict[str, list[custody.Row]], problems: list[str]) -> list[int]:
    """Check each row (an inspection, a calibration) against its one record of ``kind``.

    The row's ``record_seq`` must name it, and ``payload(conn, id)`` must equal the record's
    payload; returns the numbers of the records whose row was changed.
    """
    changed = []
    rows = dict(conn.execute(sa.select(table.c.id, table.c.record_seq)).all())
    for rid in sorted(rows):
        recs = records.get(str(rid))
        if recs is None:
            problems.append(f"{noun} #{rid}: no custody record")
            continue
        if len(recs) > 1:
            problems.append(f"{noun} #{rid}: {len(recs)} {kind} records "
                            f"(#{', #'.join(str(r.seq) for r in recs)}), expected one")
        if rows[rid] != recs[0].seq:
            problems.append(f"{noun} #{rid}: names {kind} record #{rows[rid]}, its record "
                            f"is #{recs[0].seq}")
        if canonical(payload(conn, rid)) != recs[0].payload:
            problems.append(f"{noun} #{rid}: stored {kind} differs from custody record "
                            f"#{recs[0].seq}")
            changed.append(recs[0].seq)
    problems += [f"custody record #{recs[0].seq}: {noun} #{s} is no longer in the "
                 "registry (rows deleted)" for s, recs in records.items()
                 if not s.isdigit() or int(s) not in rows]
    return changed
