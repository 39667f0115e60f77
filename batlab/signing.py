"""The lab's signing key: Ed25519, one file, created on first write.

The key lives in ``$BATLAB_KEY`` if set, else ``$XDG_CONFIG_HOME/batlab/signing-key.pem``
(default ``~/.config/batlab/``), PKCS#8 PEM, mode 0600. Its public half is named as
``ed25519:<base64 of the 32 raw bytes>``; that string is the key id a custody record and a
report page carry, and the line a league keeps in its list of lab keys. Signatures are
Ed25519 (RFC 8032) over the exact bytes given, written as base64.
"""

from __future__ import annotations

import base64
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


def _load(path: Path) -> Ed25519PrivateKey:
    try:
        key = serialization.load_pem_private_key(path.read_bytes(), password=None)
    except (OSError, ValueError, TypeError) as exc:
        raise ValueError(f"{path}: not a usable batlab signing key ({exc})") from None
    if not isinstance(key, Ed25519PrivateKey):
        raise ValueError(f"{path}: not an Ed25519 key")
    return key


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
        return _load(path)
    if not create:
        return None
    key = Ed25519PrivateKey.generate()
    pem = key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                            serialization.NoEncryption())
    try:
        path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:  # another process made it first
        return _load(path)
    except OSError as exc:
        raise ValueError(f"{path}: cannot create the signing key ({exc.strerror})") from None
    with os.fdopen(fd, "wb") as fh:
        fh.write(pem)
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


def trusted_keys(trust_file: str | os.PathLike | None = None) -> set[str]:
    """Return the key ids ``registry check`` trusts: the lab's own and a league's list.

    Parameters
    ----------
    trust_file : path, optional
        One ``ed25519:<base64>`` per line; blank lines and ``#`` comments are skipped.

    Returns
    -------
    set of str
        Key ids; the lab's own key only if it exists (checking never creates one).
    """
    keys = set()
    own = signing_key(create=False)
    if own is not None:
        keys.add(key_id(own.public_key()))
    if trust_file is None:
        return keys
    try:
        lines = Path(trust_file).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{trust_file}: cannot read the trusted keys ({exc})") from None
    for n, line in enumerate(lines, 1):
        text = line.split("#", 1)[0].strip()
        if text:
            try:
                keys.add(key_id(public_key(text)))
            except ValueError as exc:
                raise ValueError(f"{trust_file}, line {n}: {exc}") from None
    return keys
