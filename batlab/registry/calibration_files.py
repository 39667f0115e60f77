"""Calibrations that travel: a signed calibration file, its import, and the shipped ones.

A calibration file (``registry calibrations --export``) is JSON:

    {"format": "batlab calibration 1", "calibration": {model, n, false_alarms,
     false_alarm_upper95, statistic, statistic_version, summary, null, code, calibrated_at},
     "signer": "ed25519:...", "signature": SIG}

SIG is the signer's Ed25519 signature of the canonical JSON of the other three keys: the key
that ran the calibration (a league on its cluster) vouches for every clean re-test's
statistic in it. ``--import`` verifies the signature, requires the signer to be trusted
(``--trust``), and stores the calibration with its custody record, whose payload keeps the
signer and signature (``origin``): ``registry check`` verifies them again, and ``inspect``
uses it as it uses a calibration run here, unless a later key record revoked its signer.

batlab itself ships calibrations in ``batlab/builtin/calibrations/MODEL.json`` (the same
files), signed by a key listed in ``batlab/builtin/calibrations/signers.keys``; ``inspect``
and ``demo`` use the one of a bat's model when the registry holds none
(``shipped_calibration``). ``benchmarks/make_shipped_calibration.py`` makes one.
"""

from __future__ import annotations

import json
from pathlib import Path

import sqlalchemy as sa

from batlab import custody, signing
from batlab.registry.calibrations import StoredCalibration, add_calibration
from batlab.registry.chain import calibration_payload
from batlab.registry.common import sha256_bytes
from batlab.registry.schema import calibrations

FORMAT = "batlab calibration 1"
SHIPPED_DIR = Path(__file__).resolve().parents[1] / "builtin" / "calibrations"
"""Where batlab's own signed calibrations live, with ``signers.keys``."""

_FIELDS = ("model", "n", "false_alarms", "false_alarm_upper95", "statistic",
           "statistic_version", "summary", "null", "code", "calibrated_at")


def _content(c: StoredCalibration) -> dict:
    return {name: getattr(c, name) for name in _FIELDS}


def _signed_bytes(content: dict, signer: str) -> bytes:
    return custody.canonical({"format": FORMAT, "calibration": content,
                              "signer": signer}).encode("utf-8")


def export_calibration(c: StoredCalibration, key) -> dict:
    """Return calibration ``c`` as a signed file's content.

    Signed by ``key`` (the lab's); an imported calibration keeps its original signer and
    signature (its content is the same).
    """
    content = _content(c)
    if c.origin and c.origin.get("signer") and c.origin.get("signature"):
        signer, sig = c.origin["signer"], c.origin["signature"]
    else:
        signer = signing.key_id(key.public_key())
        sig = signing.sign(key, _signed_bytes(content, signer))
    return {"format": FORMAT, "calibration": content, "signer": signer, "signature": sig}


def read_calibration_file(path: str | Path) -> tuple[dict, str]:
    """Read and verify a calibration file: (its content, the file's SHA-256).

    Raises
    ------
    ValueError
        Naming the file: unreadable, not a calibration file, or changed after it was signed.
    """
    try:
        data = Path(path).read_bytes()
        doc = json.loads(data)
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: cannot read the calibration file ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT \
            or not isinstance(doc.get("calibration"), dict) \
            or set(doc["calibration"]) != set(_FIELDS):
        raise ValueError(f"{path}: not a batlab calibration file (`batlab registry "
                         "calibrations --export` writes one)")
    signer, sig = str(doc.get("signer")), str(doc.get("signature"))
    if not signing.verify(signer, _signed_bytes(doc["calibration"], signer), sig):
        raise ValueError(f"{path}: its signature does not verify for key {signer} (changed "
                         "after it was signed); nothing imported")
    return doc, sha256_bytes(data)


def import_calibration(conn: sa.Connection, path: str | Path,
                       trusted: set[str] | None) -> StoredCalibration:
    """Store a verified calibration file's calibration, naming its signer in its record.

    Raises
    ------
    ValueError
        The file does not verify, or its signer is not among ``trusted`` (None: nothing is
        trusted, so nothing is imported).
    """
    doc, file_sha = read_calibration_file(path)
    signer = doc["signer"]
    if trusted is None or signer not in trusted:
        raise ValueError(f"{path}: signed by {signer}, a key not trusted here (name it in "
                         "--trust FILE, or --trust-own for this machine's); nothing imported")
    c = doc["calibration"]
    return add_calibration(conn, c["model"], c["n"], c["false_alarms"],
                           c["false_alarm_upper95"], c["statistic"], c["summary"], c["null"],
                           c["code"], c["statistic_version"],
                           origin={"signer": signer, "signature": doc["signature"],
                                   "file_sha256": file_sha},
                           calibrated_at=c["calibrated_at"])


def origin_problems(conn: sa.Connection) -> list[str]:
    """Return a problem per imported calibration whose file signature no longer verifies.

    Read from the rows as stored (whether a row still equals its custody record is the
    coverage check's to say).
    """
    out = []
    ids = conn.execute(sa.select(calibrations.c.id).where(calibrations.c.origin_json.is_not(None))
                       .order_by(calibrations.c.id)).scalars()
    for cid in ids:
        p = calibration_payload(conn, cid)
        signer = str(p["origin"].get("signer"))
        content = {name: p.get(name) for name in _FIELDS}
        if not signing.verify(signer, _signed_bytes(content, signer),
                              str(p["origin"].get("signature"))):
            out.append(f"calibration #{cid} ({p['model']}): imported, but its signature by "
                       f"{signer} does not verify for what is stored")
    return out


def shipped_calibration(model: str, directory: Path | None = None) -> StoredCalibration | None:
    """Return batlab's own calibration of bat model ``model`` (None when none is shipped).

    ``directory/MODEL.json`` must verify and be signed by a key listed in
    ``directory/signers.keys`` (default ``SHIPPED_DIR``); else ValueError naming the file
    (a broken install; ``inspect`` then states the chance unmeasured, saying why).
    """
    directory = SHIPPED_DIR if directory is None else Path(directory)
    path = directory / f"{model}.json"
    if "/" in model or not path.is_file():
        return None
    doc, file_sha = read_calibration_file(path)
    keys = directory / "signers.keys"
    if not keys.is_file() or doc["signer"] not in signing.read_trust_file(keys):
        raise ValueError(f"{path}: signed by {doc['signer']}, not a key in {keys}")
    c = doc["calibration"]
    return StoredCalibration(0, c["model"], c["n"], c["false_alarms"],
                             c["false_alarm_upper95"], c["statistic"], c["summary"], c["null"],
                             c["code"], c["calibrated_at"], None, c["statistic_version"],
                             {"signer": doc["signer"], "signature": doc["signature"],
                              "file_sha256": file_sha, "shipped": True})
