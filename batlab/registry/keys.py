"""``registry key --rotate`` and ``--revoke``: the lab's key handed over or revoked, recorded.

Both append a ``key`` custody record (format and meaning: ``batlab.custody_keys``) in one
write transaction. A rotation makes the new key, writes it beside the old one first (a file
of its own, mode 0600), appends the handover record signed by both, and only then puts the
new key in the key file's place, keeping the old one as ``NAME.retired-FINGERPRINT.pem``: if
the process dies between, the registry's chain and the key files still agree on which key
was handed over to (the new file is there, named).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import sqlalchemy as sa
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

from batlab import custody, custody_keys, signing
from batlab.registry.chain import append_record, custody_rows, forget_keys, next_record
from batlab.registry.lock import transaction


@dataclass(frozen=True)
class KeyChange:
    """A recorded key change: the record's number, the key ended and the key now signing."""

    seq: int
    old: str
    new: str
    retired_path: str | None = None


def rotate_key(conn: sa.Connection) -> KeyChange:
    """Make a new lab key and record the handover from the current one.

    Returns
    -------
    KeyChange
        The handover record, both keys and where the old key file was kept.

    Raises
    ------
    ValueError
        This machine holds no key to hand over.
    """
    path = signing.key_path()
    old_key = signing.signing_key(create=False)
    if old_key is None:
        raise ValueError(f"{path}: no lab key to rotate (nothing was ever signed here)")
    old = signing.key_id(old_key.public_key())
    new_key = Ed25519PrivateKey.generate()
    new = signing.key_id(new_key.public_key())
    staged = path.with_name(f"{path.name}.new-{signing.fingerprint(new)}.pem")
    signing.write_key(staged, new_key)
    try:
        with transaction(conn):
            seq, prev = next_record(conn)
            payload = custody_keys.handover_payload(seq, prev, old, new_key)
            append_record(conn, "key", "rotate", None, custody.canonical(payload), key=old_key)
    except BaseException:
        staged.unlink(missing_ok=True)
        raise
    retired = path.with_name(f"{path.name}.retired-{signing.fingerprint(old)}.pem")
    os.replace(path, retired)
    os.replace(staged, path)
    forget_keys()
    return KeyChange(seq, old, new, str(retired))


def resolve(conn: sa.Connection, fingerprint: str) -> str:
    """Return the key a ``--revoke`` argument names: a key id, or a signer's fingerprint.

    ValueError when it names no key that signed this registry's records, or several.
    """
    text = fingerprint.strip()
    if text.startswith(signing.KEY_PREFIX):
        return signing.key_id(signing.public_key(text))
    hits = {s for s in custody.signers(custody_rows(conn))
            if signing.fingerprint(s).startswith(text.lower())} if len(text) >= 8 else set()
    if len(hits) != 1:
        raise ValueError(f"--revoke {fingerprint}: names {'no' if not hits else 'more than one'}"
                         " key that signed this registry (give the key, ed25519:..., or 8 or "
                         "more hex digits of its fingerprint, as `registry check` prints it)")
    return hits.pop()


def revoke_key(conn: sa.Connection, fingerprint: str) -> KeyChange:
    """Record a key as revoked from the next record on, signed by the lab's current key.

    Raises
    ------
    ValueError
        The key is unknown, or the lab's own (rotate first: a lab cannot sign without a key).
    """
    from batlab.registry.chain import lab_key_id

    key = resolve(conn, fingerprint)
    own = lab_key_id()
    if key == own:
        raise ValueError(f"--revoke {fingerprint}: that is this machine's own key; run "
                         "`batlab registry key --rotate` first, then revoke the old one")
    with transaction(conn):
        seq = append_record(conn, "key", "revoke", None,
                            custody.canonical(custody_keys.revoke_payload(key)))
    return KeyChange(seq, key, own)



def ended_keys(conn: sa.Connection) -> dict[str, str]:
    """Return the keys the chain's key records retired or revoked, with why.

    Read from the key records alone (``registry check`` verifies their signatures).
    """
    from batlab.registry.schema import custody as custody_table

    c = custody_table.c
    state = custody_keys.KeyState(None)
    for seq, prev, signer, payload in conn.execute(
            sa.select(c.seq, c.prev_sha256, c.signer, c.payload)
            .where(c.kind == "key").order_by(c.seq)):
        state.apply(int(seq), prev, signer or "", payload)
    return state.ended
