"""`batlab registry`: check, print the lab's key or the chain's head, copy, list calibrations."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict

from batlab.cli_support import add_db_argument, db_path, note_printer, say, stdout_closed

EXAMPLE = ("batlab registry check --db lab.sqlite --trust lab.keys --head 42:<sha256>\n"
           "  batlab registry head --json > head.json\n"
           "  batlab registry witness head.json --key league.pem -o witnessed.json\n"
           "  batlab registry copy --from lab.sqlite --to postgresql://lab@league/batlab\n"
           "  batlab registry calibrations --db league.sqlite --json")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the ``registry`` arguments to parser ``p``."""
    p.add_argument("action", choices=["check", "key", "head", "witness", "copy",
                                      "calibrations"],
                   help="check: verify everything stored; key: print the lab's public key "
                        "(ed25519:<base64>) for a league to keep, or --rotate / --revoke it; "
                        "head: print the chain's head, SEQ:SHA256 (--json: a statement), to "
                        "note outside the file; witness: countersign a lab's head statement "
                        "with --key; copy: copy every bat, file, inspection and custody record "
                        "--from one registry --to another; calibrations: list the stored "
                        "calibrations of bat models (fleet calibrate --store), --export or "
                        "--import one")
    p.add_argument("statement", nargs="?", default=None, metavar="HEAD.json",
                   help="witness: the head statement a lab printed (`registry head --json`)")
    p.add_argument("--model", default=None, metavar="NAME",
                   help="calibrations: only this bat model's (--export: its latest)")
    p.add_argument("--report", default=None, metavar="INDEX.html",
                   help="check: also verify a report page: its seal, what it says (verdict, "
                        "reasons, the head it shows) and its records and files")
    p.add_argument("--trust", default=None, metavar="FILE",
                   help="check, copy, calibrations --import, witness: trust exactly these "
                        "keys (one ed25519:<base64> a line) and the keys they handed over to; "
                        "without --trust or --trust-own a check verifies the signatures' "
                        "consistency, not who signed (witness: the lab keys whose heads it "
                        "countersigns)")
    p.add_argument("--trust-own", action="store_true",
                   help="check, copy, calibrations --import, witness: trust this machine's own "
                        "key too")
    p.add_argument("--witnessed", nargs="+", default=None, metavar="FILE",
                   help="check: witnessed heads (`registry witness`); fails unless the "
                        "registry extends each, and names forks between them")
    p.add_argument("--rotate", action="store_true",
                   help="key: make a new key; the handover record is signed by both")
    p.add_argument("--revoke", default=None, metavar="FINGERPRINT",
                   help="key: record this key (ed25519:<base64>, or its fingerprint as "
                        "`registry check` prints it) as revoked from the next record on")
    p.add_argument("--key", dest="witness_key", default=None, metavar="KEY.pem",
                   help="witness: the witness's (a league's) private key")
    p.add_argument("--export", default=None, metavar="FILE",
                   help="calibrations: write the latest calibration (of --model) as a file "
                        "signed by this machine's key")
    p.add_argument("--import", dest="import_file", default=None, metavar="FILE",
                   help="calibrations: store a signed calibration file; its signer must be "
                        "trusted (--trust, --trust-own)")
    p.add_argument("--from", dest="source", default=None, metavar="DB",
                   help="copy: the registry to copy (a SQLite file or a postgresql:// URL); "
                        "its custody chain must verify")
    p.add_argument("--to", dest="destination", default=None, metavar="DB",
                   help="copy: the registry to copy into (created if need be); refused, "
                        "nothing written, if it holds one of the serials")
    p.add_argument("--head", default=None, metavar="SEQ:SHA256",
                   help="check: a head printed earlier; fails if that record is no longer in "
                        "the chain (rollback, truncation, fork)")
    p.add_argument("-o", "--out", default=None, metavar="WITNESSED.json",
                   help="witness: where to write the witnessed head (default: stdout)")
    add_db_argument(p)
    p.add_argument("--json", action="store_true",
                   help="check, head, copy, calibrations: print the result as JSON")


def run(args: argparse.Namespace) -> int:
    """Run ``batlab registry ACTION``.

    Parameters
    ----------
    args : argparse.Namespace
        The options ``add_arguments`` defines.

    Returns
    -------
    int
        Exit code: for ``check`` 0 only when everything verifies, else 1 (bad input raises
        ValueError or OSError, as does a refused copy; ``batlab.cli`` prints it in one line
        and exits 2).
    """
    from batlab import signing

    if args.action == "key":
        return _key(args)
    if args.action == "copy":
        return _copy(args)
    if args.action == "witness":
        return _witness(args)
    from batlab.registry import check, open_registry, shown

    if args.action == "calibrations":
        writing = args.import_file is not None
        with open_registry(db_path(args), create=writing, readonly=not writing) as conn:
            return _calibrations(conn, args)
    path = db_path(args)
    warn = None if args.action == "check" else note_printer("registry")  # check says it all
    with open_registry(path, create=False, readonly=True, warn=warn) as conn:
        if args.action == "head":
            return _head(conn, path, args.json)
        from batlab.registry import read_witnessed

        trusted = signing.trusted_keys(args.trust, args.trust_own)
        witnessed = [read_witnessed(f) for f in args.witnessed or []]
        res = check(conn, trusted, args.head, witnessed)
        page = None
        if args.report:
            from batlab.registry import now_utc
            from batlab.report_check import check_page

            page = {"path": str(args.report), "checked_at": now_utc(),
                    "problems": check_page(conn, args.report, trusted)}
            page["ok"] = not page["problems"]
    try:
        _print(res, shown(path), args.json, trusted is not None, page)
        sys.stdout.flush()  # (a pipe's buffer: its reader may have left before the flush)
    except BrokenPipeError:  # `registry check | head -3`: the reader left; the status stands
        stdout_closed()
    return 0 if res.ok and (page is None or page["ok"]) else 1


def _head(conn, path, as_json: bool) -> int:
    """Print the chain's head: ``SEQ:SHA256``, or with ``as_json`` the head statement."""
    from batlab.registry import custody_rows, head, head_statement, now_utc, shown

    text = head(conn)
    if text is None:
        raise ValueError(f"{shown(path)}: the registry holds no custody record yet")
    print(json.dumps(head_statement(custody_rows(conn), now_utc())) if as_json else text)
    return 0


def _key(args: argparse.Namespace) -> int:
    """Print the lab's public key, or rotate it, or revoke a key (``registry key``)."""
    from batlab import signing

    if args.rotate and args.revoke:
        raise ValueError("--rotate and --revoke are two steps: rotate first, then revoke")
    if not args.rotate and not args.revoke:
        print(signing.key_id(signing.signing_key(create=True).public_key()))
        return 0
    from batlab.registry import open_registry, revoke_key, rotate_key, shown

    path = db_path(args)
    with open_registry(path, create=False) as conn:
        change = rotate_key(conn) if args.rotate else revoke_key(conn, args.revoke)
    if args.rotate:
        print(change.new)
        print(f"batlab registry: {shown(path)}: key {change.old} handed over to {change.new} "
              f"(record #{change.seq}, signed by both); the old key is kept in "
              f"{change.retired_path}", file=sys.stderr)
    else:
        print(f"{shown(path)}: key {change.old} revoked from record #{change.seq} on (signed "
              f"by {change.new})")
    return 0


def _witness(args: argparse.Namespace) -> int:
    """Countersign a lab's head statement (``registry witness HEAD.json --key KEY.pem``)."""
    from pathlib import Path

    from batlab import signing
    from batlab.pipeline import check_output
    from batlab.pipeline.files import atomic_write
    from batlab.registry import now_utc, witness_head

    if not args.statement or not args.witness_key:
        raise ValueError("witness needs HEAD.json (`registry head --json` on the lab's "
                         "registry) and --key KEY.pem (the witness's private key)")
    if args.out is not None:
        check_output(args.out, "-o/--out", "file")
    try:
        stmt = json.loads(Path(args.statement).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ValueError(f"{args.statement}: cannot read the head statement ({exc})") from None
    if not isinstance(stmt, dict):
        raise ValueError(f"{args.statement}: not a batlab head statement")
    known = signing.trusted_keys(args.trust, args.trust_own)
    if known is not None and stmt.get("lab_key") not in known:
        raise ValueError(f"{args.statement}: a head of key {stmt.get('lab_key')}, not one of "
                         "the lab keys trusted (--trust); nothing witnessed")
    done = json.dumps(witness_head(stmt, signing.load_key(args.witness_key), now_utc(),
                              args.statement))
    if args.out is None:
        print(done)
    else:
        atomic_write(args.out, lambda tmp: Path(tmp).write_text(done + "\n"))
    return 0


def _print(res, path, as_json: bool, signers_checked: bool, page: dict | None = None) -> None:
    """Print a check's result: JSON, or a summary line and one line per problem and note.

    ``signers_checked`` False (no ``--trust``, no ``--trust-own``): the summary says that
    the signatures were checked for consistency only (JSON: ``signers_checked``). A report
    page checked against the registry (``--report``) gets its own line: its problems are
    the page's, not the registry's, and it says when it was checked.
    """
    if as_json:
        print(json.dumps({**asdict(res), "ok": res.ok and (page is None or page["ok"]),
                          "registry_ok": res.ok, "signers_checked": signers_checked,
                          **({"report": page} if page else {})}))
        return
    state = "intact" if res.ok else "DAMAGED OR CHANGED"
    if res.ok and not signers_checked:
        state += (" (signatures consistent; who signed was not checked: give --trust KEYS "
                  "or --trust-own)")
    say(f"{path}: {state}: {res.n_records} custody records, {res.n_files} files")
    if res.head:
        say(f"  chain head {res.head}")
    for line in res.problems:
        say(f"  problem: {line}")
    for line in res.notes:
        say(f"  note: {line}")
    if res.first_changed is not None:
        say(f"  first changed record: #{res.first_changed}")
    if page is not None:
        when = page["checked_at"][:19].replace("T", " ")
        state = ("verified against this registry" if page["ok"] else
                 "DOES NOT MATCH this registry (the page is at fault, not the registry)")
        say(f"{page['path']}: {state}, checked {when} UTC (its seal, verdict, reasons, "
            "records, files and registry head)")
        for line in page["problems"]:
            say(f"  problem: {line}")


def _registry_arg(text: str):
    """Return a ``--from``/``--to`` value as ``open_registry`` takes it (URL or path)."""
    from pathlib import Path

    from batlab.registry import is_url

    return text if is_url(text) else Path(text).expanduser()


def _copy(args: argparse.Namespace) -> int:
    """Run ``batlab registry copy --from SRC --to DST``: print what was copied."""
    from batlab import signing
    from batlab.registry import copy_registry, open_registry, shown

    if not args.source or not args.destination:
        raise ValueError("copy needs --from SRC and --to DST (SQLite files or postgresql:// "
                         "URLs)")
    source, destination = _registry_arg(args.source), _registry_arg(args.destination)
    if str(source) == str(destination):
        raise ValueError(f"{shown(source)}: --from and --to name the same registry")
    trusted = signing.trusted_keys(args.trust, args.trust_own)
    with open_registry(source, create=False, readonly=True,
                       warn=note_printer("registry copy")) as src, \
            open_registry(destination) as dst:
        res = copy_registry(src, dst, trusted, shown(source), shown(destination))
    if args.json:
        print(json.dumps({"from": shown(source), "to": shown(destination), **asdict(res)}))
    else:
        print(f"{shown(source)} -> {shown(destination)}: copied {res.n_bats} bats, "
              f"{res.n_files} files, {res.n_inspections} inspections, {res.n_records} custody "
              f"records ({res.mode}); both chains verified")
        print(f"  source head {res.source_head}")
        print(f"  destination head {res.head}")
    return 0


def _calibrations(conn, args: argparse.Namespace) -> int:
    """List the stored calibrations, or ``--export`` / ``--import`` one (a signed file).

    The list (JSON: one object each, without the per-re-test null) names each one's
    statistic and its version, and an imported one's signer.
    """
    from batlab.registry import list_calibrations

    if args.export and args.import_file:
        raise ValueError("--export and --import: one at a time")
    if args.export:
        return _export(conn, args)
    if args.import_file:
        return _import(conn, args)
    rows = []
    for c in list_calibrations(conn, args.model):
        f = [v for v in c.null.get(c.statistic) or [] if v is not None]
        q = {} if not f else {k: float(x) for k, x in zip(
            ("50", "90", "99", "max"), [*_quantiles(f, (0.5, 0.9, 0.99)), max(f)],
            strict=True)}
        rows.append({"calibration": c.id, "model": c.model, "n": c.n,
                     "false_alarms": c.false_alarms,
                     "false_alarm_upper95": c.false_alarm_upper95,
                     "inconclusive": c.summary.get("inconclusive"), "statistic": c.statistic,
                     "statistic_version": c.statistic_version,
                     "signer": (c.origin or {}).get("signer"),
                     "with_statistic": len(f), "quantiles": q, "serial": c.summary.get("serial"),
                     "seed": c.summary.get("seed"), "false_alarm": c.summary.get("false_alarm"),
                     "codes": c.summary.get("codes"), "code": c.code,
                     "core_s_per_bat": c.summary.get("core_s_per_bat"),
                     "calibrated_at": c.calibrated_at, "record_seq": c.record_seq})
    if args.json:
        print(json.dumps(rows))
        return 0
    if not rows:
        print("no calibration stored" + (f" for bat model {args.model}" if args.model else ""))
    for r in rows:
        q = r["quantiles"]
        quant = "" if not q else (f"; {r['statistic']} 50/90/99 % {q['50']:.2f} / {q['90']:.2f}"
                                  f" / {q['99']:.2f}, largest {q['max']:.2f}")
        print(f"#{r['calibration']} bat model {r['model']}: {r['n']:,} clean re-tests, "
              f"{r['false_alarms']} called altered (rate below {r['false_alarm_upper95']:.2g}, "
              f"95 %), {r['inconclusive']} inconclusive{quant}; {r['statistic']} version "
              f"{r['statistic_version'] or 'unknown (stored before versions)'}"
              + (f"; imported, signed by {r['signer']}" if r["signer"] else ""))
        print(f"  bat {r['serial']}, seed {r['seed']}, level {r['false_alarm']}; judged by "
              + ", ".join(f"batlab {c} ({n})" for c, n in (r["codes"] or {}).items())
              + f"; stored {r['calibrated_at'][:19]} UTC, custody record #{r['record_seq']}")
    return 0


def _export(conn, args: argparse.Namespace) -> int:
    """Write the latest calibration (of ``--model``) as a file signed by the lab's key."""
    from pathlib import Path

    from batlab.pipeline import check_output
    from batlab.pipeline.files import atomic_write
    from batlab.registry import (
        export_calibration,
        lab_key,
        latest_calibration,
        list_calibrations,
    )

    check_output(args.export, "--export", "file")
    models = sorted({c.model for c in list_calibrations(conn, args.model)})
    if len(models) != 1:
        said = ("no calibration stored" if not models
                else f"several bat models stored ({', '.join(models)})")
        raise ValueError(f"--export: {said}; name one with --model")
    c = latest_calibration(conn, models[0])
    doc = export_calibration(c, lab_key())
    atomic_write(args.export, lambda tmp: Path(tmp).write_text(json.dumps(doc) + "\n"))
    print(f"{args.export}: calibration #{c.id} of bat model {c.model} ({c.n:,} clean "
          f"re-tests, {c.statistic} version {c.statistic_version}), signed by {doc['signer']}")
    return 0


def _import(conn, args: argparse.Namespace) -> int:
    """Store a signed calibration file's calibration (its signer must be trusted)."""
    from batlab import signing
    from batlab.registry import import_calibration

    c = import_calibration(conn, args.import_file,
                           signing.trusted_keys(args.trust, args.trust_own))
    print(f"{args.import_file}: imported as calibration #{c.id} of bat model {c.model} "
          f"({c.n:,} clean re-tests, {c.statistic} version {c.statistic_version}), signed by "
          f"{c.origin['signer']}; custody record #{c.record_seq}")
    return 0


def _quantiles(values: list[float], qs: tuple[float, ...]) -> list[float]:
    """Return the quantiles of ``values`` (linear interpolation, as numpy.quantile)."""
    import numpy as np

    return [float(x) for x in np.quantile(np.asarray(values, dtype=float), qs)]
