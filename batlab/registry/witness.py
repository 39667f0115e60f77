"""Witnessed heads: a lab's head as a signed statement, countersigned by a league, and checked.

``head_statement`` (``batlab registry head --json``) states the chain's head: the lab's key
(the head record's signer), its number and hash, the time it was read, the head record itself
with its signature (so anyone can verify that the lab's key signed a record of that number and
hash) and the first 16 hex digits of every record's hash in order (``record_hashes``: what
lets a later check name the first record that differs). ``witness`` (``batlab registry
witness``) verifies the statement and countersigns it with a league's key. ``check_witnessed``
(``registry check --witnessed``) proves that a registry extends each witnessed head (its record
#SEQ has the witnessed hash, which commits to every record before it) and finds forks: two
heads signed by one key whose histories differ.

This is RFC 9162's signed tree head and consistency check reduced to a hash chain: a
checker here holds the whole registry (it re-hashes every record anyway), so "does this log
extend that head" is answered by the record at the head's number, with no consistency proof
(docs/registry.md, "Witnessed heads").
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from batlab import custody, signing

HEAD_FORMAT = "batlab head 1"
WITNESSED_FORMAT = "batlab witnessed head 1"
PREFIX_HEX = 16
"""Hex digits of each record's hash a statement keeps (64 bits: a record named wrongly as
the first that differs would need a hash prefix collision; the head's full hash decides)."""

_RECORD_FIELDS = ("seq", "kind", "subject", "content_sha256", "prev_sha256", "recorded_at",
                  "signer")


def head_statement(rows: list[custody.Row], now: str) -> dict:
    """Return the chain's head as a statement (``registry head --json``).

    Parameters
    ----------
    rows : list of custody.Row
        The whole chain, in order (not empty).
    now : str
        The time it is read (UTC, ISO 8601).

    Returns
    -------
    dict
        ``format``, ``lab_key``, ``seq``, ``sha256``, ``time``, ``record`` (the head record's
        fields and ``signature``) and ``record_hashes``.
    """
    last = rows[-1]
    record = {name: getattr(last, name) for name in _RECORD_FIELDS}
    record["signature"] = last.signature
    return {"format": HEAD_FORMAT, "lab_key": last.signer, "seq": last.seq,
            "sha256": last.record_sha256, "time": now, "record": record,
            "record_hashes": "".join(r.record_sha256[:PREFIX_HEX] for r in rows)}


def statement_problem(stmt: dict) -> str | None:
    """Return what is wrong with a head statement (None: the lab's key signed that head)."""
    try:
        rec = stmt["record"]
        row = custody.Row(rec["seq"], rec["kind"], rec["subject"], None, rec["content_sha256"],
                          rec["prev_sha256"], stmt["sha256"], rec["recorded_at"],
                          rec["signer"], rec.get("signature"))
        seq, hashes = int(stmt["seq"]), str(stmt["record_hashes"])
    except (KeyError, TypeError, ValueError):
        return "not a batlab head statement"
    if stmt.get("format") != HEAD_FORMAT or row.seq != seq:
        return "not a batlab head statement"
    if row.signer != stmt.get("lab_key") or row.expected_hash() != stmt["sha256"]:
        return "its record does not hash to its head"
    if not row.signature_ok():
        return f"the head record's signature does not verify for key {row.signer}"
    if len(hashes) != PREFIX_HEX * seq or hashes[-PREFIX_HEX:] != stmt["sha256"][:PREFIX_HEX]:
        return "its record hashes do not end at its head"
    return None


def _witness_bytes(head: dict, witness_key: str, witnessed_at: str) -> bytes:
    return custody.canonical({"format": WITNESSED_FORMAT, "head": head, "witness": witness_key,
                              "witnessed_at": witnessed_at}).encode("utf-8")


def witness_head(stmt: dict, key, now: str, where: str = "head") -> dict:
    """Countersign a lab's head statement with a league's key (``registry witness``).

    Parameters
    ----------
    stmt : dict
        ``head_statement``'s output, as the lab sent it.
    key : Ed25519PrivateKey
        The witness's key.
    now : str
        When it is witnessed (UTC).
    where : str
        The statement's file, for the message.

    Returns
    -------
    dict
        ``format``, ``head`` (the statement), ``witness`` (its key), ``witnessed_at``,
        ``signature`` (the witness's, over the canonical JSON of the rest).

    Raises
    ------
    ValueError
        The statement is not one the lab's key signed.
    """
    why = statement_problem(stmt)
    if why:
        raise ValueError(f"{where}: {why}; nothing witnessed")
    who = signing.key_id(key.public_key())
    return {"format": WITNESSED_FORMAT, "head": stmt, "witness": who, "witnessed_at": now,
            "signature": signing.sign(key, _witness_bytes(stmt, who, now))}


def read_witnessed(path: str | Path) -> dict:
    """Read a witnessed head file; ValueError naming it when it is not one."""
    try:
        w = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ValueError(f"{path}: cannot read the witnessed head ({exc})") from None
    if not isinstance(w, dict) or w.get("format") != WITNESSED_FORMAT \
            or not isinstance(w.get("head"), dict):
        raise ValueError(f"{path}: not a witnessed head (`batlab registry witness` writes one)")
    return {**w, "file": str(path)}


@dataclass(frozen=True)
class WitnessCheck:
    """What ``check_witnessed`` found.

    Problems and notes, one line each, and the first record that differs from a witnessed
    head (None: none does).
    """

    problems: list[str]
    notes: list[str]
    first_changed: int | None = None


def _name(w: dict) -> str:
    h = w["head"]
    return (f"witnessed head {h.get('seq')}:{str(h.get('sha256'))[:12]} ({w['file']}, "
            f"witnessed by {w.get('witness')} at {w.get('witnessed_at')})")


def _first_difference(hashes: str, known: list[str], seq: int) -> int | None:
    """Return the first record (1-based, up to ``seq``) whose hash prefix differs."""
    for i in range(seq):
        theirs = hashes[i * PREFIX_HEX:(i + 1) * PREFIX_HEX]
        if i >= len(known) or known[i][:PREFIX_HEX] != theirs:
            return i + 1
    return None


def _witness_problem(w: dict, trusted: set[str] | None) -> str | None:
    key = w.get("witness")
    if not isinstance(key, str) or not signing.verify(
            key, _witness_bytes(w["head"], key, str(w.get("witnessed_at"))),
            str(w.get("signature"))):
        return "the witness's signature does not verify (changed after it was witnessed)"
    if trusted is not None and key not in trusted:
        return f"witnessed by a key not trusted here ({key})"
    return statement_problem(w["head"])


def check_witnessed(rows: list[custody.Row], witnessed: list[dict],
                    trusted: set[str] | None) -> WitnessCheck:
    """Prove the chain extends each witnessed head; find forks between them.

    Parameters
    ----------
    rows : list of custody.Row
        The registry's chain, in order.
    witnessed : list of dict
        ``read_witnessed``'s output, one per file.
    trusted : set of str or None
        Keys a witness must hold (None: any whose signature verifies).

    Returns
    -------
    WitnessCheck
        A problem per head the chain does not extend (naming the first record that differs)
        and per pair of heads of one key that fork; a note per head it extends.
    """
    problems, notes, changed = [], [], []
    known = [r.record_sha256 for r in rows]
    good = []
    for w in witnessed:
        why = _witness_problem(w, trusted)
        if why:
            problems.append(f"{_name(w)}: {why}")
            continue
        good.append(w)
        h = w["head"]
        seq = int(h["seq"])
        if seq <= len(known) and known[seq - 1] == h["sha256"]:
            notes.append(f"{_name(w)}: the registry extends it (records #1..#{seq} unchanged)")
            continue
        first = _first_difference(h["record_hashes"], known, seq)
        if seq > len(known) and (first is None or first > len(known)):
            problems.append(f"{_name(w)}: record #{seq} is gone (the chain ends at "
                            f"#{len(known)}: rolled back or truncated)")
        else:
            changed.append(first or seq)
            problems.append(f"{_name(w)}: the registry does not extend it: record "
                            f"#{first or seq} is the first that differs (history rewritten "
                            "or forked after the head was witnessed)")
    problems += _forks(good)
    return WitnessCheck(problems, notes, min(changed, default=None))


def _forks(good: list[dict]) -> list[str]:
    """Name every pair of heads of one lab key whose histories differ (a fork)."""
    out = []
    for i, a in enumerate(good):
        for b in good[i + 1:]:
            ha, hb = a["head"], b["head"]
            if ha["lab_key"] != hb["lab_key"]:
                continue
            n = min(int(ha["seq"]), int(hb["seq"]))
            short = ha if int(ha["seq"]) == n else hb
            other = hb if short is ha else ha
            first = _first_difference(other["record_hashes"],
                                      [short["record_hashes"][k:k + PREFIX_HEX]
                                       for k in range(0, n * PREFIX_HEX, PREFIX_HEX)], n)
            same_head = other["record_hashes"][(n - 1) * PREFIX_HEX:n * PREFIX_HEX] \
                == short["sha256"][:PREFIX_HEX]
            if first is not None or not same_head or (
                    int(ha["seq"]) == int(hb["seq"]) and ha["sha256"] != hb["sha256"]):
                out.append(f"fork: {_name(a)} and {_name(b)} are two histories signed by one "
                           f"key ({ha['lab_key']}): they differ from record #{first or n} on")
    return out
