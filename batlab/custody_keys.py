"""Key records in the custody chain: a key handed over to a new one, or revoked.

Two kinds of ``key`` custody record (subject ``rotate`` or ``revoke``), their payloads
canonical JSON:

- handover (``batlab registry key --rotate``): ``{"action": "rotate", "old": OLD, "new":
  NEW, "new_signature": SIG}``. The record is signed by OLD as every record is; SIG is NEW's
  Ed25519 signature of ``handover_bytes(seq, prev_sha256, OLD, NEW)``, so the record is
  signed by both keys and bound to its place in this chain. From the next record on, OLD is
  retired: a record it signs fails, and a check that trusted OLD trusts NEW.
- revocation (``batlab registry key --revoke FINGERPRINT``): ``{"action": "revoke", "key":
  KEY}``, signed by the lab's current key. From the next record on, a record KEY signs fails,
  trusted or not (a thief's records after the theft was recorded).

``KeyState`` is the fold ``custody.check_chain`` runs over the chain, record by record, after
``predecessors`` has added to the trusted keys every key a trusted key took over from (the
new key signed the handover: it vouches for the old key's records before it).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from batlab import signing

HANDOVER = "batlab key handover"
"""What a handover's new key signs, with the record's place and both keys."""


def handover_bytes(seq: int, prev_sha256: str, old: str, new: str) -> bytes:
    """Return the bytes a handover's new key signs (canonical JSON, UTF-8)."""
    return json.dumps({"statement": HANDOVER, "seq": seq, "prev_sha256": prev_sha256,
                       "old": old, "new": new}, sort_keys=True,
                      separators=(",", ":")).encode("utf-8")


def handover_payload(seq: int, prev_sha256: str, old: str, new_key) -> dict:
    """Return a handover record's payload: ``old`` handing over to ``new_key`` (private)."""
    new = signing.key_id(new_key.public_key())
    return {"action": "rotate", "old": old, "new": new,
            "new_signature": signing.sign(new_key, handover_bytes(seq, prev_sha256, old, new))}


def revoke_payload(key: str) -> dict:
    """Return a revocation record's payload."""
    return {"action": "revoke", "key": key}


def _handover(seq: int, prev_sha256: str, signer: str, payload: str | None) -> tuple | None:
    """Return (old, new) of a valid handover record (None: not one, or not signed by both)."""
    try:
        p = json.loads(payload or "")
        old, new, sig = p["old"], p["new"], p["new_signature"]
    except (ValueError, TypeError, KeyError):
        return None
    if p.get("action") != "rotate" or old != signer or not isinstance(new, str):
        return None
    if not signing.verify(new, handover_bytes(seq, prev_sha256, old, new), str(sig)):
        return None
    return old, new


def predecessors(key_records: list[tuple], trusted: set[str]) -> set[str]:
    """Return ``trusted`` with every key a trusted key took over from, back along the chain.

    Parameters
    ----------
    key_records : list of tuple
        The chain's key records in order: (seq, prev_sha256, signer, payload).
    trusted : set of str
        The keys given.

    Returns
    -------
    set of str
        Those keys and, for each valid handover OLD -> NEW with NEW in the set (walking
        from the last handover to the first), OLD: its records before the handover count.
    """
    out = set(trusted)
    for rec in reversed(key_records):
        pair = _handover(*rec)
        if pair is not None and pair[1] in out:
            out.add(pair[0])
    return out


@dataclass
class KeyState:
    """The keys' state as the chain is read: trusted (None: not asked) and ended keys.

    Attributes
    ----------
    trusted : set of str or None
        The keys trusted at this point of the chain (the ones given, and every key a trusted
        key handed over to); None: a consistency check, nobody's key trusted or not.
    ended : dict
        Key id -> why it may sign no more (``retired by handover record #N`` or ``revoked by
        record #N``).
    """

    trusted: set[str] | None
    ended: dict[str, str] = field(default_factory=dict)

    def why_not(self, signer: str) -> str | None:
        """Return why a verified signature by ``signer`` does not count here (None: it does)."""
        if signer in self.ended:
            return f"signed by key {signer}, {self.ended[signer]}"
        if self.trusted is not None and signer not in self.trusted:
            return f"signed by a key not trusted here ({signer})"
        return None

    def apply(self, seq: int, prev_sha256: str, signer: str, payload: str | None) -> str | None:
        """Take in key record ``seq`` (already verified as signed by ``signer``).

        Returns
        -------
        str or None
            What is wrong with it (the state left as it was), or None.
        """
        try:
            p = json.loads(payload or "")
            action = p["action"]
        except (ValueError, TypeError, KeyError):
            return "not a key record"
        if action == "revoke":
            key = p.get("key")
            if not isinstance(key, str):
                return "names no key to revoke"
            self.ended.setdefault(key, f"revoked by record #{seq}")
            if self.trusted is not None:
                self.trusted.discard(key)
            return None
        if action != "rotate":
            return f"unknown key action {action!r}"
        old, new = p.get("old"), p.get("new")
        if old != signer:
            return f"hands over key {old}, but is signed by {signer}"
        if _handover(seq, prev_sha256, signer, payload) is None:
            return f"the new key's signature does not verify ({new})"
        self.ended.setdefault(old, f"retired by handover record #{seq}")
        if self.trusted is not None and old in self.trusted:
            self.trusted.discard(old)
            self.trusted.add(new)
        return None
