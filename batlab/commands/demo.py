"""`batlab demo`: the whole lab workflow on the virtual rig, no hardware and no input files.

The built-in bat (``batlab/builtin/``: a smooth 34 in pro-style ash profile and its meta.json)
is tested on the virtual rig as the real board would behave (4 % stiffer and 3 % lighter than
the handbook, E/G = 13, Timoshenko, 3 g accelerometer, bungees, 0.5 % noise). Its baseline is
registered; weeks later it is re-tested after moisture moved (+0.8 points), the accelerometer
was re-mounted 0.05 in away, and someone corked it (1 in core, 10 in deep, 1 in plug, fill
0.3 of the wood's density). The re-test is inspected against the registry and reported.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from batlab.cli_support import (
    add_db_argument,
    add_out_argument,
    db_path,
    note_printer,
    progress_printer,
)

EXAMPLE = "batlab demo -o demo/"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab demo`` to its sub-parser."""
    add_out_argument(p, "work directory for the test files, registry and report (default: "
                        "a new temporary directory, removed at the end)", "DIR")
    add_db_argument(p)
    p.add_argument("--seed", type=int, default=7, help="noise seed of the baseline (re-test: +1)")
    p.add_argument("--json", action="store_true", help="print the verdict JSON on stdout")


def run(args: argparse.Namespace) -> int:
    """Simulate, register and inspect the built-in bat on the virtual rig.

    Without ``--out`` the work goes into a temporary directory removed at the end (the
    report is then not kept, and no report path is stored).

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
    from batlab.pipeline import admit

    admit(args, note_printer("demo"), outputs={"out": "dir"},
          registry=db_path(args) if args.db else None, create=True)
    if args.out:
        return _run_in(Path(args.out), args, keep=True)
    with tempfile.TemporaryDirectory(prefix="batlab-demo-") as tmp:
        return _run_in(Path(tmp), args, keep=False)


def _run_in(work: Path, args: argparse.Namespace, keep: bool) -> int:
    """Run the demo in ``work``; with ``keep`` False its files are about to be removed."""
    from batlab import pipeline
    from batlab.formatting import readable
    from batlab.registry import open_registry
    from batlab.report import check_destination, write_report

    progress = progress_printer("demo")
    check_destination(work, "--out")
    db = db_path(args) if args.db else work / "registry.sqlite"  # a file, or a server's URL
    with open_registry(db) as conn:  # a damaged --db is refused before the simulation
        files = pipeline.simulate_demo_pair(work, args.seed, progress)
        profile, meta, baseline, retest = files.profile, files.meta, files.baseline, files.retest
        done = pipeline.register_files(conn, profile, meta, baseline, replace=True,
                                       progress=progress)
        serial = done.record.serial
        result = pipeline.inspect_registered(conn, serial, retest, refit_baseline=True,
                                             progress=progress, baseline_fit=done.baseline.fit)
        stored = pipeline.store_inspection(conn, result, retest)
        inputs = pipeline.report_inputs(result, done.record.meta,
                                        pipeline.provenance(conn, stored=stored))
        report = write_report(work / "report", inputs)
        if keep:
            pipeline.note_report(conn, stored, str(report))
    out = pipeline.result_dict(result)
    where = f"under {work}; report: {report}" if keep else "(not kept: give --out DIR to keep them)"
    progress(f"wrote the tests, registry and report {where}")
    if args.json:
        print(json.dumps(out), flush=True)
        return 0
    print(readable(out))
    print(f"truth: corked, 1.00 in core from 24.0 to 33.0 in, fill 0.30 "
          f"(plus moisture +{pipeline.DEMO_RETEST['moisture_pct']} points and a "
          "re-mounted sensor)")
    if not keep:
        print("report: not kept (the work directory was temporary; give --out DIR to keep "
              "the files and the report)")
        return 0
    print(f"report: {report}")
    print(f"files:  {work} (profile.csv, meta.json, baseline.uff, retest.uff); "
          f"registry: {db}")
    print(f"again:  batlab inspect --serial {serial} {retest} --db {db}")
    return 0
