"""`batlab registry check`: integrity, stored files and the chain of custody."""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict, replace

from batlab.cli_support import add_db_argument, db_path

EXAMPLE = "batlab registry check --db lab.sqlite"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab registry`` to its sub-parser."""
    p.add_argument("action", choices=["check"], help="check: verify everything stored")
    p.add_argument("--report", default=None, metavar="INDEX.html",
                   help="also verify a report page against the registry: its verdict and "
                        "registration records and file hashes must be there, unchanged")
    add_db_argument(p)
    p.add_argument("--json", action="store_true", help="print the result as JSON on stdout")


def run(args: argparse.Namespace) -> int:
    """Check the registry (integrity, stored files' hashes, custody chain).

    Parameters
    ----------
    args : argparse.Namespace
        The options ``add_arguments`` defines.

    Returns
    -------
    int
        Exit code: 0 when everything verifies, 1 otherwise (bad input raises ValueError or OSError;
        ``batlab.cli`` prints it in one line and exits 2).
    """
    from batlab.registry import check, open_registry

    path = db_path(args)
    with open_registry(path, create=False) as conn:
        res = check(conn)
        if args.report:
            res = replace(res, problems=res.problems + _check_report(conn, args.report))
    if args.json:
        print(json.dumps({**asdict(res), "ok": res.ok}))
    else:
        state = "intact" if res.ok else "DAMAGED OR CHANGED"
        print(f"{path}: {state}: {res.n_records} custody records, {res.n_files} files")
        if res.head_sha256:
            print(f"  chain head sha256 {res.head_sha256}")
        for line in res.problems:
            print(f"  problem: {line}")
        for line in res.notes:
            print(f"  note: {line}")
        if res.first_changed is not None:
            print(f"  first changed record: #{res.first_changed}")
    return 0 if res.ok else 1


def _check_report(conn, page_path: str) -> list[str]:
    """Problems of a report page against the registry (empty: it matches)."""
    from pathlib import Path

    from batlab.registry import custody_record, has_file
    from batlab.report import provenance_hashes

    try:
        page = Path(page_path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{page_path}: cannot read the report ({exc})") from None
    hashes = provenance_hashes(page)
    if "verdict_record" not in hashes:
        return [f"{page_path}: carries no verdict record (not a report of a stored inspection)"]
    problems = []
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
    return problems
