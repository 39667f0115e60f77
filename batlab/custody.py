"""The custody chain's records: canonical bytes, hashes, signatures, the head, their check.

A record (schema 4) is the canonical JSON (sorted keys, no spaces, UTF-8) of

    {"seq", "kind", "subject", "content_sha256", "prev_sha256", "recorded_at", "signer"}

``record_sha256`` is the SHA-256 of those bytes and ``signature`` the signer's Ed25519
signature of them, so the chain is plain text and numbers that any SQL dialect stores as is.
``prev_sha256`` is the previous record's ``record_sha256`` (64 zeros for the first). The head
of the chain is written ``SEQ:SHA256`` (RFC 9162's signed tree head, reduced to a hash chain).

A file record's payload covers every column of the stored file's row:
``{"name", "size", "sha256"}`` (``file_payload``), hashed into ``content_sha256`` like any
other payload, so an edited name or size fails. File records written before that (issue 48)
kept the file's own SHA-256 as ``content_sha256`` and a payload ``{"name"}`` that no hash
covers; they still verify (their content hash is the file's), and their row's name is checked
against that payload, which ``check_chain`` notes is all it can do for them.

Records written before schema 4 are unsigned and hashed the old way (newline-joined fields,
``legacy_record_hash``); they are accepted only as the chain's first records and only when the
signed ``seal`` record right after them says how many there are.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass

from batlab import signing
from batlab.custody_keys import KeyState, predecessors

GENESIS_SHA256 = "0" * 64
KINDS = ("file", "reference", "verdict", "seal", "calibration", "key")


def canonical(obj) -> str:
    """Return canonical JSON (sorted keys, no spaces, no NaN): the text a record hashes."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def sha256_text(text: str) -> str:
    """Return the hex SHA-256 of ``text`` encoded as UTF-8."""
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def legacy_record_hash(seq: int, kind: str, subject: str, content_sha256: str,
                       prev_sha256: str, recorded_at: str) -> str:
    """Return a schema-3 record's hash: SHA-256 of its fields joined by newlines."""
    return sha256_text("\n".join((str(seq), kind, subject, content_sha256, prev_sha256,
                                  recorded_at)))


def file_payload(name: str, size: int, sha256: str) -> str:
    """Return a file record's payload: canonical JSON of its row's name, size and SHA-256."""
    return canonical({"name": name, "sha256": sha256, "size": int(size)})


def name_only_file_record(r: Row) -> bool:
    """Return whether a file record is of the first format: its payload (the name) unhashed.

    Its ``content_sha256`` is the file's own hash (its subject) rather than its payload's.
    """
    return r.kind == "file" and r.content_sha256 == r.subject


def record_bytes(seq: int, kind: str, subject: str, content_sha256: str, prev_sha256: str,
                 recorded_at: str, signer: str) -> bytes:
    """Return the canonical bytes of a schema-4 record: what is hashed and signed."""
    return canonical({"seq": seq, "kind": kind, "subject": subject,
                      "content_sha256": content_sha256, "prev_sha256": prev_sha256,
                      "recorded_at": recorded_at, "signer": signer}).encode("utf-8")


@dataclass(frozen=True)
class Row:
    """One stored custody record as read from the table (``signer`` None: legacy)."""

    seq: int
    kind: str
    subject: str
    payload: str | None
    content_sha256: str
    prev_sha256: str
    record_sha256: str
    recorded_at: str
    signer: str | None
    signature: str | None

    def expected_hash(self) -> str:
        """Return the hash the record's fields give (legacy rule when unsigned)."""
        if self.signer is None:
            return legacy_record_hash(self.seq, self.kind, self.subject, self.content_sha256,
                                      self.prev_sha256, self.recorded_at)
        return hashlib.sha256(self._bytes()).hexdigest()

    def _bytes(self) -> bytes:
        return record_bytes(self.seq, self.kind, self.subject, self.content_sha256,
                            self.prev_sha256, self.recorded_at, self.signer or "")

    def signature_ok(self) -> bool:
        """Return whether the signature is the named signer's over the record's bytes."""
        return bool(self.signer and self.signature
                    and signing.verify(self.signer, self._bytes(), self.signature))


def head_text(seq: int, record_sha256: str) -> str:
    """Return the head of the chain as ``SEQ:SHA256``."""
    return f"{seq}:{record_sha256}"


def parse_head(text: str) -> tuple[int, str]:
    """Return (seq, sha256) of a head written ``SEQ:SHA256``; ValueError if malformed."""
    seq, _, sha = text.strip().partition(":")
    if not seq.isdigit() or len(sha) != 64 or any(c not in "0123456789abcdef" for c in sha):
        raise ValueError(f"--head {text!r}: expected SEQ:SHA256 as `batlab registry head` "
                         "prints it")
    return int(seq), sha


def legacy_prefix(rows: list[Row]) -> int:
    """Return how many leading unsigned records a valid seal record vouches for (0 if none).

    The seal is the first signed record; its payload ``{"legacy_records": N}`` must name
    exactly the unsigned records before it.
    """
    first_signed = next((r for r in rows if r.signer is not None), None)
    if first_signed is None or first_signed.kind != "seal":
        return 0
    try:
        n = int(json.loads(first_signed.payload or "{}").get("legacy_records", 0))
    except (ValueError, TypeError, AttributeError):
        return 0
    return n if n == first_signed.seq - 1 else 0


def _why_changed(r: Row, prev: str, expect_seq: int) -> str | None:
    """Return why a record fails its own hash, link or content (None when it holds)."""
    if r.seq != expect_seq:
        return f"records #{expect_seq}..#{r.seq - 1} removed or renumbered"
    if r.kind not in KINDS:
        return f"unknown kind {r.kind!r}"
    if r.prev_sha256 != prev:
        return "its link to the previous record is broken"
    if r.record_sha256 != r.expected_hash():
        return "its hash does not match its fields"
    if name_only_file_record(r):  # the first file records: the file's own hash
        return None
    if sha256_text(r.payload or "") != r.content_sha256:
        return "its content does not match its content hash"
    if r.kind == "file" and _payload_field(r, "sha256") != r.subject:
        return "its file hash was changed"
    return None


def _payload_field(r: Row, key: str):
    """Return one field of a record's JSON payload (None when it has none)."""
    try:
        value = json.loads(r.payload or "{}")
    except ValueError:
        return None
    return value.get(key) if isinstance(value, dict) else None


def _why_unsigned(r: Row, n_legacy: int, keys: KeyState) -> str | None:
    """Return what is wrong with a record's signature (None when it counts here).

    It must verify for the key it names, that key must not have been retired or revoked by
    an earlier record, and, when ``keys`` trusts a set of keys, be one of them.
    """
    if r.signer is None:
        return None if r.seq <= n_legacy else "unsigned"
    if not r.signature_ok():
        return f"its signature does not verify for key {r.signer}"
    return keys.why_not(r.signer)


@dataclass(frozen=True)
class ChainCheck:
    """The chain's own verdict: problems (one line each), notes, first changed record."""

    problems: list[str]
    notes: list[str]
    first_changed: int | None


def check_chain(rows: list[Row], trusted: set[str] | None) -> ChainCheck:
    """Verify every record's sequence, link, hash, content hash and signature.

    Parameters
    ----------
    rows : list of Row
        The custody table ordered by ``seq``.
    trusted : set of str or None
        Key ids (``ed25519:<base64>``) whose signatures are accepted, every key one of them
        handed over to, and every key one of them took over from, for its records before the
        handover (``custody_keys``); None: any key's, as long as it verifies and
        was not retired or revoked before (the signatures' consistency, not who signed).

    Returns
    -------
    ChainCheck
        One problem per failing record, naming its number, kind and subject.
    """
    problems, notes, first = [], [], None
    n_legacy = legacy_prefix(rows)
    if n_legacy:
        notes.append(f"records #1..#{n_legacy} are unsigned legacy records (written before "
                     f"schema 4), sealed by signed record #{n_legacy + 1}")
    old_files = [r.seq for r in rows if name_only_file_record(r)]
    if old_files:
        notes.append(f"{len(old_files)} file record(s) (#{old_files[0]}..#{old_files[-1]}) "
                     "were written before file records covered a file's name and size: "
                     "their content hash is the file's, their name is checked against the "
                     "record's payload, which no hash covers")
    if trusted is not None:
        trusted = predecessors([(r.seq, r.prev_sha256, r.signer or "", r.payload)
                                for r in rows if r.kind == "key"], trusted)
    keys = KeyState(None if trusted is None else set(trusted))
    prev, expect = GENESIS_SHA256, 1
    for r in rows:
        why = _why_changed(r, prev, expect) or _why_unsigned(r, n_legacy, keys)
        if why is None and r.kind == "key":
            why = keys.apply(r.seq, r.prev_sha256, r.signer or "", r.payload)
        if why:
            first = r.seq if first is None else first
            problems.append(f"custody record #{r.seq} ({r.kind} {r.subject[:16]}): {why}")
        prev, expect = r.record_sha256, r.seq + 1
    return ChainCheck(problems, notes, first)


def signers(rows: list[Row]) -> dict[str, list[int]]:
    """Return each key that signed records, with its first and last record's number."""
    out: dict[str, list[int]] = {}
    for r in rows:
        if r.signer:
            out.setdefault(r.signer, [r.seq, r.seq])[1] = r.seq
    return out


def check_head(rows: list[Row], head: str) -> list[str]:
    """Return the problem (if any) with a head noted earlier: it must still be in the chain."""
    seq, sha = parse_head(head)
    by_seq = {r.seq: r for r in rows}
    if seq not in by_seq:
        last = rows[-1].seq if rows else 0
        return [f"head {seq}:{sha[:12]}: record #{seq} is gone (chain ends at #{last}: "
                "rolled back or truncated)"]
    if by_seq[seq].record_sha256 != sha:
        return [f"head {seq}:{sha[:12]}: record #{seq} is now {by_seq[seq].record_sha256[:12]} "
                "(rolled back, rewritten or forked)"]
    return []
