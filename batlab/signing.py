"""The lab's signing key: Ed25519, one file, created on first write.

The key lives in ``$BATLAB_KEY`` if set, else ``$XDG_CONFIG_HOME/batlab/signing-key.pem``
(default ``~/.config/batlab/``), PKCS#8 PEM, mode 0600. Its public half is named as
``ed25519:<base64 of the 32 raw bytes>``; that string is the key id a custody record and a
report page carry, and the line a league keeps in its list of lab keys. Signatures are
Ed25519 (RFC 8032) over the exact bytes given, written as base64.
"""

from __future__ import annotations

import base64
import hashlib
import os
import sys
from pathlib import Path

from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric.ed25519 import (
    Ed25519PrivateKey,
    Ed25519PublicKey,
)

KEY_PREFIX = "ed25519:"


def key_path(env: dict | None = None) -> Path:
    """Return where the lab's signing key is kept.

    Parameters
    ----------
    env : dict, optional
        Environment (default ``os.environ``): ``BATLAB_KEY``, else ``XDG_CONFIG_HOME``.

    Returns
    -------
    Path
        ``$BATLAB_KEY``, else ``$XDG_CONFIG_HOME/batlab/signing-key.pem``, else
        ``~/.config/batlab/signing-key.pem``.
    """
    env = os.environ if env is None else env
    if env.get("BATLAB_KEY"):
        return Path(env["BATLAB_KEY"]).expanduser()
    return config_dir(env) / "signing-key.pem"


def config_dir(env: dict | None = None) -> Path:
    """Return the lab's batlab configuration folder.

    ``$XDG_CONFIG_HOME/batlab``, else ``~/.config/batlab`` (the signing key, the lab
    profile, ``batlab.lab``).
    """
    env = os.environ if env is None else env
    base = env.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base).expanduser() / "batlab"


def _refuse_open_mode(path: Path) -> None:
    """Refuse a key file that group or others may read or write, as ssh refuses one.

    The mode bits are read (``stat``), not tried: root may read any file, but a key left
    0644 is readable by every user of the machine all the same.
    """
    try:
        mode = path.stat().st_mode & 0o777
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the signing key ({exc.strerror})") from None
    if mode & 0o077:
        raise ValueError(f"{path}: signing key is open to group or others (mode {mode:04o}): "
                         f"refused, as ssh refuses such keys; run `chmod 600 {path}`")


def load_key(path: str | os.PathLike) -> Ed25519PrivateKey:
    """Load an Ed25519 private key (PKCS#8 PEM); ValueError naming the file otherwise.

    A key file open to group or others is refused (``_refuse_open_mode``).
    """
    path = Path(path)
    _refuse_open_mode(path)
    try:
        key = serialization.load_pem_private_key(path.read_bytes(), password=None)
    except (OSError, ValueError, TypeError) as exc:
        raise ValueError(f"{path}: not a usable batlab signing key ({exc})") from None
    if not isinstance(key, Ed25519PrivateKey):
        raise ValueError(f"{path}: not an Ed25519 key")
    return key


def write_key(path: str | os.PathLike, key: Ed25519PrivateKey) -> None:
    """Write ``key`` to a new file ``path`` (PKCS#8 PEM, mode 0600); OSError if it exists."""
    pem = key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                            serialization.NoEncryption())
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "wb") as fh:
        fh.write(pem)


def signing_key(create: bool = True) -> Ed25519PrivateKey | None:
    """Load the lab's private key, creating it (mode 0600) on first use if ``create``.

    A new key is announced once on stderr with its path.

    Parameters
    ----------
    create : bool
        Create the key when there is none (a write); False returns None instead.

    Returns
    -------
    Ed25519PrivateKey or None
        The key, or None when there is none and ``create`` is False.
    """
    path = key_path()
    if path.exists():
        return load_key(path)
    if not create:
        return None
    key = Ed25519PrivateKey.generate()
    try:
        path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        write_key(path, key)
    except FileExistsError:  # another process made it first
        return load_key(path)
    except OSError as exc:
        raise ValueError(f"{path}: cannot create the signing key ({exc.strerror})") from None
    print(f"batlab: created the lab's signing key {path} (keep it private; "
          "`batlab registry key` prints its public key)", file=sys.stderr)
    return key


def key_id(public: Ed25519PublicKey) -> str:
    """Return the public key as ``ed25519:<base64>`` (its id in records and trust lists)."""
    raw = public.public_bytes(serialization.Encoding.Raw, serialization.PublicFormat.Raw)
    return KEY_PREFIX + base64.b64encode(raw).decode("ascii")


def public_key(key_id_text: str) -> Ed25519PublicKey:
    """Return the public key named by ``ed25519:<base64>``; ValueError if malformed."""
    if not key_id_text.startswith(KEY_PREFIX):
        raise ValueError(f"not an ed25519 public key: {key_id_text[:40]!r}")
    try:
        raw = base64.b64decode(key_id_text[len(KEY_PREFIX):], validate=True)
        return Ed25519PublicKey.from_public_bytes(raw)
    except ValueError:
        raise ValueError(f"not an ed25519 public key: {key_id_text[:40]!r}") from None


def sign(key: Ed25519PrivateKey, data: bytes) -> str:
    """Return the base64 Ed25519 signature of ``data``."""
    return base64.b64encode(key.sign(data)).decode("ascii")


def verify(key_id_text: str, data: bytes, signature: str) -> bool:
    """Return whether ``signature`` (base64) is the key's Ed25519 signature of ``data``."""
    try:
        public_key(key_id_text).verify(base64.b64decode(signature, validate=True), data)
    except (ValueError, InvalidSignature):
        return False
    return True


def fingerprint(key_id_text: str) -> str:
    """Return a key's short name: the first 16 hex digits of the SHA-256 of its 32 bytes."""
    raw = public_key(key_id_text).public_bytes(serialization.Encoding.Raw,
                                               serialization.PublicFormat.Raw)
    return hashlib.sha256(raw).hexdigest()[:16]


def read_trust_file(trust_file: str | os.PathLike) -> set[str]:
    """Return the key ids listed in a trust file.

    Parameters
    ----------
    trust_file : path
        One ``ed25519:<base64>`` per line; blank lines and ``#`` comments are skipped.

    Returns
    -------
    set of str
        The key ids; ValueError naming the file and line of a malformed one.
    """
    try:
        lines = Path(trust_file).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{trust_file}: cannot read the trusted keys ({exc})") from None
    keys = set()
    for n, line in enumerate(lines, 1):
        text = line.split("#", 1)[0].strip()
        if text:
            try:
                keys.add(key_id(public_key(text)))
            except ValueError as exc:
                raise ValueError(f"{trust_file}, line {n}: {exc}") from None
    return keys


def trusted_keys(trust_file: str | os.PathLike | None = None,
                 own: bool = False) -> set[str] | None:
    """Return the key ids a check trusts: exactly those it was given.

    Parameters
    ----------
    trust_file : path, optional
        A list of keys (``read_trust_file``).
    own : bool
        Trust this machine's own key too (``--trust-own``); it must exist.

    Returns
    -------
    set of str or None
        The keys listed and, if ``own``, the machine's; None when neither was given: the
        check then verifies the signatures' consistency only, not who signed.
    """
    if trust_file is None and not own:
        return None
    keys = set() if trust_file is None else read_trust_file(trust_file)
    if own:
        mine = signing_key(create=False)
        if mine is None:
            raise ValueError(f"{key_path()}: --trust-own, but this machine holds no batlab "
                             "key")
        keys.add(key_id(mine.public_key()))
    return keys
