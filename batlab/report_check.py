"""A report page's seal and its check against the registry (``registry check --report``).

A page written from a stored inspection is sealed: the lab's Ed25519 signature of the whole
page (every visible word and number, the figures, the head it was written at) without the
seal itself, in ``<meta name="batlab-seal" content="ed25519:KEY SIGNATURE">``. Checking a
page verifies that signature against the trusted keys, then the page's content against the
registry: its verdict and registration records (numbers and hashes), its files, the verdict
words and reasons of the stored inspection, and that the head it shows is still in the chain.
"""

from __future__ import annotations

import html
import re
from pathlib import Path

import sqlalchemy as sa

from batlab import custody, signing
from batlab.safe_text import for_page

_SEAL = re.compile(r'<meta name="batlab-seal" content="(ed25519:[A-Za-z0-9+/=]+) '
                   r'([A-Za-z0-9+/=]+)">')
_HEAD = re.compile(r"<td>Registry head when written</td><td><code>(\d+:[0-9a-f]{64})</code>")
_STATUS = re.compile(r"<div class='verdict (\w+)'>")
_NUMBER_SPAN = re.compile(r"<span class='n'>([^<]*)</span>")


def seal_page(page: str) -> str:
    """Return ``page`` with the lab's signature of its bytes inserted before ``</head>``."""
    key = signing.signing_key(create=True)
    sig = signing.sign(key, page.encode("utf-8"))
    tag = f'<meta name="batlab-seal" content="{signing.key_id(key.public_key())} {sig}">'
    return page.replace("</head>", tag + "</head>", 1)


def _seal_problems(page: str, where: str, trusted: set[str]) -> list[str]:
    """Problems with the page's seal (empty: a key of ``trusted`` signed exactly this page)."""
    m = _SEAL.search(page)
    if m is None:
        return [f"{where}: carries no seal (not written by batlab, or the seal was removed)"]
    body = page[:m.start()] + page[m.end():]
    if not signing.verify(m.group(1), body.encode("utf-8"), m.group(2)):
        return [f"{where}: its content was changed after it was written (the seal does not "
                "verify)"]
    if m.group(1) not in trusted:
        return [f"{where}: sealed by a key not trusted here ({m.group(1)})"]
    return []


def _content_problems(conn: sa.Connection, page: str, where: str,
                      verdict_seq: int) -> list[str]:
    """Check the page's verdict words, reasons and head against the inspection and chain."""
    from batlab.registry import custody_rows, inspection_by_record

    problems = []
    stored = inspection_by_record(conn, verdict_seq)
    if stored is None:
        return [f"{where}: no stored inspection has verdict record #{verdict_seq}"]
    shown = _STATUS.search(page)
    if shown is None or shown.group(1) != stored.status:
        problems.append(f"{where}: shows verdict {shown.group(1) if shown else 'none'!r}, "
                        f"inspection #{stored.id} is {stored.status!r}")
    words = _NUMBER_SPAN.sub(r"\1", page)  # the report keeps each number on one line
    problems += [f"{where}: reason missing or changed: {reason!r}"
                 for reason in stored.verdict.get("reasons") or []
                 if for_page(html.escape(reason)) not in words]
    head = _HEAD.search(page)
    if head is None:
        problems.append(f"{where}: shows no registry head")
    else:
        problems += [f"{where}: {p}" for p in custody.check_head(custody_rows(conn),
                                                                  head.group(1))]
    return problems


def check_page(conn: sa.Connection, page_path: str | Path,
               trusted: set[str] | None) -> list[str]:
    """Return the problems of a report page against the registry (empty: it verifies).

    Parameters
    ----------
    conn : sqlalchemy.Connection
        The registry.
    page_path : str or Path
        The report's ``index.html``.
    trusted : set of str or None
        Key ids whose seals are accepted; None (no ``--trust``): any key that signed records
        of this registry (consistency, not who signed).

    Returns
    -------
    list of str
        One line per problem, each naming the page.
    """
    from batlab.registry import custody_record, has_file

    try:
        page = Path(page_path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{page_path}: cannot read the report ({exc})") from None
    hashes = provenance_hashes(page)
    if "verdict_record" not in hashes:
        return [f"{page_path}: carries no verdict record (not a report of a stored inspection)"]
    if trusted is None:
        from batlab.registry import custody_rows

        trusted = set(custody.signers(custody_rows(conn)))
    problems = _seal_problems(page, str(page_path), trusted)
    for key in ("verdict_record", "reference_record"):
        if key not in hashes:
            continue
        try:
            rec = custody_record(conn, hashes[key])
        except ValueError as exc:
            problems.append(f"{page_path}: {exc}")
            continue
        if rec.record_sha256 != hashes[key + "_sha256"]:
            problems.append(f"{page_path}: custody record #{rec.seq} has hash "
                            f"{rec.record_sha256[:12]}, the report says "
                            f"{hashes[key + '_sha256'][:12]}")
    for key in ("baseline_sha256", "retest_sha256"):
        sha = hashes.get(key)
        if sha and not has_file(conn, sha):
            problems.append(f"{page_path}: file {sha[:12]} ({key[:-7]}) not in the registry")
    return problems + _content_problems(conn, page, str(page_path), hashes["verdict_record"])


def provenance_hashes(page: str) -> dict:
    """Read the hashes a report page carries.

    The hashes a report page carries (its Provenance rows, as ``_provenance`` writes them):
    {"baseline_sha256", "retest_sha256", "verdict_record", "verdict_record_sha256",
    "reference_record", "reference_record_sha256"} (missing keys absent).
    """
    out: dict = {}
    for label, key in (("Baseline file", "baseline_sha256"), ("Re-test file", "retest_sha256")):
        m = re.search(rf"<td>{label}</td><td>[^<]*<br><code>sha256 ([0-9a-f]{{64}})</code>", page)
        if m:
            out[key] = m.group(1)
    for label, key in (("Verdict record", "verdict_record"),
                       ("Registration record", "reference_record")):
        m = re.search(rf"<td>{label}</td><td>#(\d+)<br><code>sha256 ([0-9a-f]{{64}})</code>", page)
        if m:
            out[key], out[key + "_sha256"] = int(m.group(1)), m.group(2)
    return out
