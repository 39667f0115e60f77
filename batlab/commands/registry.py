"""`batlab registry`: check, print the lab's key or the chain's head, copy, list calibrations."""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict

from batlab.cli_support import add_db_argument, db_path, note_printer

EXAMPLE = ("batlab registry check --db lab.sqlite --head 42:<sha256>\n"
           "  batlab registry copy --from lab.sqlite --to postgresql://lab@league/batlab\n"
           "  batlab registry calibrations --db league.sqlite --json")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the ``registry`` arguments to parser ``p``."""
    p.add_argument("action", choices=["check", "key", "head", "copy", "calibrations"],
                   help="check: verify everything stored; key: print the lab's public key "
                        "(ed25519:<base64>) for a league to keep; head: print the chain's "
                        "head, SEQ:SHA256, to note outside the file; copy: copy every bat, "
                        "file, inspection and custody record --from one registry --to "
                        "another; calibrations: list the stored calibrations of bat models "
                        "(fleet calibrate --store)")
    p.add_argument("--model", default=None, metavar="NAME",
                   help="calibrations: only this bat model's")
    p.add_argument("--report", default=None, metavar="INDEX.html",
                   help="check: also verify a report page: its seal, what it says (verdict, "
                        "reasons, the head it shows) and its records and files")
    p.add_argument("--trust", default=None, metavar="FILE",
                   help="check, copy: also trust these lab public keys (one ed25519:<base64> "
                        "a line)")
    p.add_argument("--from", dest="source", default=None, metavar="DB",
                   help="copy: the registry to copy (a SQLite file or a postgresql:// URL); "
                        "its custody chain must verify")
    p.add_argument("--to", dest="destination", default=None, metavar="DB",
                   help="copy: the registry to copy into (created if need be); refused, "
                        "nothing written, if it holds one of the serials")
    p.add_argument("--head", default=None, metavar="SEQ:SHA256",
                   help="check: a head printed earlier; fails if that record is no longer in "
                        "the chain (rollback, truncation, fork)")
    add_db_argument(p)
    p.add_argument("--json", action="store_true",
                   help="check, copy, calibrations: print the result as JSON")


def run(args: argparse.Namespace) -> int:
    """Run ``batlab registry ACTION`` (check, key, head).

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
        print(signing.key_id(signing.signing_key(create=True).public_key()))
        return 0
    if args.action == "copy":
        return _copy(args)
    from batlab.registry import check, head, open_registry, shown

    if args.action == "calibrations":
        with open_registry(db_path(args), create=False, readonly=True) as conn:
            return _calibrations(conn, args)
    path = db_path(args)
    warn = None if args.action == "check" else note_printer("registry")  # check says it all
    with open_registry(path, create=False, readonly=True, warn=warn) as conn:
        if args.action == "head":
            text = head(conn)
            if text is None:
                raise ValueError(f"{shown(path)}: the registry holds no custody record yet")
            print(text)
            return 0
        trusted = signing.trusted_keys(args.trust)
        res = check(conn, trusted, args.head)
        page = None
        if args.report:
            from batlab.registry import now_utc
            from batlab.report_check import check_page

            page = {"path": str(args.report), "checked_at": now_utc(),
                    "problems": check_page(conn, args.report, trusted)}
            page["ok"] = not page["problems"]
    _print(res, shown(path), args.json, page)
    return 0 if res.ok and (page is None or page["ok"]) else 1


def _print(res, path, as_json: bool, page: dict | None = None) -> None:
    """Print a check's result: JSON, or a summary line and one line per problem and note.

    A report page checked against the registry (``--report``) gets its own line: its
    problems are the page's, not the registry's, and it says when it was checked.
    """
    if as_json:
        print(json.dumps({**asdict(res), "ok": res.ok and (page is None or page["ok"]),
                          "registry_ok": res.ok, **({"report": page} if page else {})}))
        return
    state = "intact" if res.ok else "DAMAGED OR CHANGED"
    print(f"{path}: {state}: {res.n_records} custody records, {res.n_files} files")
    if res.head:
        print(f"  chain head {res.head}")
    for line in res.problems:
        print(f"  problem: {line}")
    for line in res.notes:
        print(f"  note: {line}")
    if res.first_changed is not None:
        print(f"  first changed record: #{res.first_changed}")
    if page is not None:
        when = page["checked_at"][:19].replace("T", " ")
        state = ("verified against this registry" if page["ok"] else
                 "DOES NOT MATCH this registry (the page is at fault, not the registry)")
        print(f"{page['path']}: {state}, checked {when} UTC (its seal, verdict, reasons, "
              "records, files and registry head)")
        for line in page["problems"]:
            print(f"  problem: {line}")


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
    trusted = signing.trusted_keys(args.trust)
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
    """Print the stored calibrations (JSON: one object each, without the per-re-test null)."""
    from batlab.registry import list_calibrations

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
              f"95 %), {r['inconclusive']} inconclusive{quant}")
        print(f"  bat {r['serial']}, seed {r['seed']}, level {r['false_alarm']}; judged by "
              + ", ".join(f"batlab {c} ({n})" for c, n in (r["codes"] or {}).items())
              + f"; stored {r['calibrated_at'][:19]} UTC, custody record #{r['record_seq']}")
    return 0


def _quantiles(values: list[float], qs: tuple[float, ...]) -> list[float]:
    """Return the quantiles of ``values`` (linear interpolation, as numpy.quantile)."""
    import numpy as np

    return [float(x) for x in np.quantile(np.asarray(values, dtype=float), qs)]
