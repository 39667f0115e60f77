"""`batlab inspect`: the lab's verdict on a re-test of a bat (docs/contract.md).

Two forms, the same verdict:
    batlab inspect --profile P --meta M --baseline B.uff --retest R.uff
                   [--retest-meta retest.json] [--retest-profile retest_profile.csv]
                   [--json]                                                    (stateless)
    batlab inspect --serial S R.uff [--retest-meta retest.json]
                   [--retest-profile retest_profile.csv] [--db PATH] [--json]
                   [--again]                                   (registered bat; stored)

A registered bat's re-test file already inspected (same SHA-256, baseline and false-alarm
rate, no --retest-meta, no --retest-profile) is not inspected or stored again: its stored
verdict is printed; ``--again`` re-runs and stores it anew. The chance an unaltered bat
differs this much is stated from the registry's latest calibration of the bat's model
(``fleet calibrate --store``), else said unmeasured; the stateless form reads calibrations
from ``--db``, else ``$BATLAB_DB`` when set, and stores nothing.
"""

from __future__ import annotations

import argparse
import json
import os
from contextlib import contextmanager
from pathlib import Path

from batlab.cli_support import (
    add_db_argument,
    add_out_argument,
    db_path,
    note_printer,
    progress_printer,
)

EXAMPLE = ("batlab inspect --serial HX-1004 retest.uff -o report/\n"
           "  batlab inspect --profile profile.csv --meta meta.json --baseline baseline.uff \\\n"
           "      --retest retest.uff --json")
USAGE = ("\n  batlab inspect --serial S RETEST [options]                  (registered bat)"
         "\n  batlab inspect --profile P --meta M --baseline B --retest RETEST [options]"
         "  (stateless)")
"""The two forms, one a line (argparse would list RETEST twice in one line)."""


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab inspect`` to its sub-parser."""
    p.usage = USAGE
    p.add_argument("retest_file", nargs="?", default=None, metavar="RETEST",
                   help="the re-test file, registry form (--serial S RETEST)")
    p.add_argument("--serial", default=None, help="a registered bat's serial number")
    p.add_argument("--profile", default=None, help="profile.csv (stateless form)")
    p.add_argument("--meta", default=None, help="meta.json (stateless form)")
    p.add_argument("--baseline", default=None, help="baseline test file (stateless form)")
    p.add_argument("--retest", default=None, metavar="RETEST",
                   help="the re-test file, stateless form (the same file as RETEST above)")
    p.add_argument("--retest-meta", default=None, metavar="RETEST_JSON",
                   help="retest.json: the re-test's weight_lb, accelerometer_mass_g, "
                        "temperature_c, tested_on, humidity_pct, conditioned_h and "
                        "moisture readings [{x_in, mc_pct}, ...] (every key optional)")
    p.add_argument("--retest-profile", default=None, metavar="RETEST_PROFILE_CSV",
                   help="retest_profile.csv: the caliper profile measured again at the "
                        "re-test (x_in,diameter_in,angle_deg)")
    p.add_argument("--false-alarm", type=float, default=0.01, metavar="RATE",
                   help="the decision's false-alarm rate, a fraction (default 0.01)")
    add_out_argument(p, "write the HTML report to DIR/index.html (created if needed; "
                        "checked writable before any work)", "DIR", old="--report")
    p.add_argument("--plots", default=None, metavar="DIR",
                   help="write the report's figures as PNG files to DIR")
    p.add_argument("--again", action="store_true",
                   help="with --serial: inspect and store a re-test file already inspected "
                        "(default: print its stored verdict)")
    add_db_argument(p)  # the stateless form: where calibrations are read (--db or $BATLAB_DB)
    p.add_argument("--json", action="store_true",
                   help="print the verdict as one JSON object on stdout")


def _retest_path(args) -> str:
    if args.retest and args.retest_file and args.retest != args.retest_file:
        raise ValueError("give the re-test once (--retest R.uff or a positional R.uff)")
    path = args.retest or args.retest_file
    if not path:
        raise ValueError("no re-test file given (--retest R.uff)")
    return path


def run(args: argparse.Namespace) -> int:
    """Inspect a re-test for alteration, stateless or against the registry.

    Parameters
    ----------
    args : argparse.Namespace
        The options ``add_arguments`` defines.

    Returns
    -------
    int
        Exit code: 0 (bad input raises ValueError or OSError; ``batlab.cli`` prints
        it in one line and exits 2).
    """
    from batlab import pipeline
    from batlab.formatting import readable
    from batlab.registry import AlreadyStored, open_registry

    progress = progress_printer("inspect")
    retest = _retest_path(args)
    if not 0 < args.false_alarm < 0.5:
        raise ValueError(f"--false-alarm {args.false_alarm:g}: expected a rate between 0 and "
                         "0.5")
    stateless = (args.profile, args.meta, args.baseline)
    if args.serial and any(stateless):
        raise ValueError("--serial takes the bat from the registry: drop --profile, --meta "
                         "and --baseline")
    if not args.serial and not all(stateless):
        raise ValueError("give --serial S, or all of --profile, --meta and --baseline")
    db = db_path(args) if args.serial else None
    pipeline.admit(args, note_printer("inspect"), outputs={"out": "dir", "plots": "dir"},
                   registry=db)  # before any work: nothing is made or fitted for bad input
    if args.serial:
        with open_registry(db, create=False) as conn:
            once = not (args.again or args.retest_meta or args.retest_profile)
            done = pipeline.already_inspected(conn, args.serial, retest, args.false_alarm) \
                if once else None
            if done is not None:
                return _print_stored(args, conn, done, retest, progress, readable)
            drawn = bool(args.out or args.plots)  # the element map only for a report
            result = pipeline.inspect_registered(conn, args.serial, retest, args.false_alarm,
                                                 refit_baseline=drawn, progress=progress,
                                                 retest_meta_path=args.retest_meta,
                                                 with_map=drawn,
                                                 retest_profile_path=args.retest_profile)
            try:  # asked again inside the storing transaction: another process may have
                stored = pipeline.store_inspection(  # stored this re-test meanwhile
                    conn, result, retest, args.false_alarm,
                    retest_meta=bool(args.retest_meta), once=once)
            except AlreadyStored as same:
                return _print_stored(args, conn, same.inspection, retest, progress, readable)
            progress(f"stored as inspection {pipeline.bat_inspection_number(conn, stored)} of "
                     f"{result.serial} (registry inspection #{stored.id}, custody record "
                     f"#{stored.record_seq})")
            _print(args, pipeline.result_dict(result), readable)
            if args.out or args.plots:
                bat = pipeline.stored_bat(conn, stored)
                prov = pipeline.provenance(conn, stored=stored)
                try:
                    path = _report(args, pipeline.report_inputs(result, bat.meta, prov),
                                   progress)
                except (OSError, ValueError) as exc:
                    raise ValueError(
                        f"the verdict is stored (inspection #{stored.id}) but the report failed "
                        f"({exc}); draw it again with: batlab report {result.serial} "
                        f"--inspection {stored.id}{_db_option(args)}") from None
                if path is not None:
                    pipeline.note_report(conn, stored, path)
    else:
        with _calibrations(args) as (conn, why):
            result = pipeline.inspect_files(args.profile, args.meta, args.baseline, retest,
                                            args.false_alarm, progress, args.retest_meta,
                                            with_map=bool(args.out or args.plots),
                                            retest_profile_path=args.retest_profile,
                                            conn=conn, unmeasured_why=why)
        _print(args, pipeline.result_dict(result), readable)
        if args.out or args.plots:
            prov = pipeline.provenance(baseline_sha256=pipeline.file_sha256(args.baseline),
                                       retest_sha256=pipeline.file_sha256(retest))
            meta = pipeline.read_meta_dict(args.meta)
            _report(args, pipeline.report_inputs(result, meta, prov), progress)
    return 0


def _print_stored(args, conn, done, retest: str, progress, readable) -> int:
    """Print the stored verdict of a re-test file already inspected (and its report if asked)."""
    from batlab import pipeline

    progress(f"{retest} was already inspected (inspection #{done.id} of {done.serial}, "
             f"{done.inspected_at}): its stored verdict, not stored again (--again re-runs it)")
    _print(args, pipeline.stored_contract_dict(done.verdict, done.inputs), readable)
    if args.out or args.plots:
        path = _report(args, pipeline.stored_report_inputs(conn, done.serial, done.id,
                                                           progress), progress)
        if path is not None:
            pipeline.note_report(conn, done, path)
    return 0


@contextmanager
def _calibrations(args):
    """Open the registry the stateless form reads calibrations from: ``(conn, why)``.

    ``--db`` (it must exist), else ``$BATLAB_DB`` when set (a registry not there yet is
    said, not an error), read-only; else none: ``conn`` None and ``why`` says, in words, why
    the chance is unmeasured. Nothing is stored.
    """
    from batlab.registry import open_registry

    if not args.db and not os.environ.get("BATLAB_DB"):
        yield None, ("no registry was given to read calibrations from (--db or $BATLAB_DB)")
        return
    path = db_path(args)
    if not args.db and isinstance(path, Path) and not path.exists():
        yield None, "no registry at $BATLAB_DB to read calibrations from"
        return
    with open_registry(path, create=False, readonly=True) as conn:
        yield conn, None


def _db_option(args) -> str:
    """Return `` --db DB`` (shell-quoted) when the command was given ``--db``, else ``""``."""
    import shlex

    return f" --db {shlex.quote(str(args.db))}" if args.db else ""


def _print(args, out: dict, readable) -> None:
    """Print the verdict on stdout, before anything optional (report, plots) can fail."""
    from batlab.cli_support import say

    if args.json:
        print(json.dumps(out), flush=True)
    else:
        say(readable(out))


def _report(args, inputs, progress) -> str | None:
    from batlab.report import write_plots, write_report

    if not args.out:
        progress("writing the plots")
        write_plots(args.plots, inputs)
        progress(f"plots: {args.plots}")
        return None
    progress("writing the report")
    path = write_report(args.out, inputs, plots_dir=args.plots)
    progress(f"report: {path}" + (f", plots: {args.plots}" if args.plots else ""))
    return str(path)
