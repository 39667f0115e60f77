"""`batlab fleet`: a fleet's work spread over a Dask cluster (docs/scale.md).

    batlab fleet inspect DIR --db DB [--scheduler tcp://HOST:PORT] [--json]
    batlab fleet calibrate --profile P --meta M --n N [--seed S] [--scheduler ...] [--json]
                           [-o rows.jsonl [--resume]] [--store [--db DB] [--model NAME]]

``inspect`` judges every ``SERIAL.uff`` of DIR (``SERIAL.json``: its retest.json;
``SERIAL.profile.csv``: its re-test caliper profile) against the registry as ``batlab
inspect --serial`` does and stores each verdict; ``--json`` prints
the list of the objects ``batlab inspect --json`` prints (a refused re-test:
``{"serial", "retest", "error"}``, and exit 1). ``calibrate`` inspects N simulated clean
re-tests of one bat (every nuisance and legal grip) and bounds its false-alarm rate;
``--resume`` keeps the rows already in ``-o``'s file and inspects only the missing re-tests
(rows judged by other code are said, with both versions); ``--store`` keeps the clean
re-tests' F and status in the registry as the bat model's measured null (a signed custody
record), from which ``inspect`` states the chance of the model's bats. The cost is printed
as core-seconds a bat (stderr, and ``core_s_per_bat`` in the JSON).
Without ``--scheduler`` a local cluster sized to the machine does the work; progress goes
to stderr.
"""

from __future__ import annotations

import argparse
import json
import os
import time

from batlab.cli_support import add_db_argument, db_path, note_printer, progress_printer

EXAMPLE = ("batlab fleet calibrate --profile profile.csv --meta meta.json --n 3000 --seed 1 "
           "--json\n  batlab fleet inspect retests/ --db lab.sqlite --json")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the options of ``batlab fleet`` to its sub-parser."""
    p.add_argument("action", choices=["inspect", "calibrate"],
                   help="inspect: every SERIAL.uff of DIR against the registry, stored; "
                        "calibrate: the false-alarm rate on N clean re-tests of one bat")
    p.add_argument("folder", nargs="?", default=None, metavar="DIR",
                   help="inspect: the folder of SERIAL.uff re-tests (SERIAL.json and "
                        "SERIAL.profile.csv beside)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="a running Dask scheduler (tcp://HOST:PORT); default: a local "
                        "cluster, one worker process per core")
    add_db_argument(p)
    p.add_argument("--profile", default=None, help="calibrate: the bat's profile.csv")
    p.add_argument("--meta", default=None, help="calibrate: the bat's meta.json (points_in)")
    p.add_argument("--n", type=int, default=None, help="calibrate: clean re-tests to inspect")
    p.add_argument("--seed", type=int, default=0, help="calibrate: the study's seed (default 0)")
    p.add_argument("-o", "--out", default=None, metavar="ROWS_JSONL",
                   help="calibrate: also write one JSON line per clean re-test here, as "
                        "each finishes")
    p.add_argument("--resume", action="store_true",
                   help="calibrate: keep the rows already in -o's file (the last one is "
                        "inspected again and must agree) and inspect only the missing ones")
    p.add_argument("--store", action="store_true",
                   help="calibrate: keep the clean re-tests' F and status in the registry "
                        "(--db) as the bat model's measured null, a signed custody record; "
                        "inspect states its bats' chance from it")
    p.add_argument("--model", default=None, metavar="NAME",
                   help="calibrate --store: the bat model's name (default: meta.json's "
                        "model, else SPECIES-LENGTHin-HASH of the profile)")
    p.add_argument("--false-alarm", type=float, default=0.01,
                   help="false-alarm rate of the decision (default 0.01)")
    p.add_argument("--json", action="store_true", help="print the result as JSON on stdout")


def run(args: argparse.Namespace) -> int:
    """Run ``batlab fleet inspect`` or ``batlab fleet calibrate``.

    Parameters
    ----------
    args : argparse.Namespace
        The options ``add_arguments`` defines.

    Returns
    -------
    int
        Exit code: 0, or 1 when a re-test of ``inspect`` was refused (bad input raises
        ValueError or OSError; ``batlab.cli`` prints it in one line and exits 2).
    """
    from batlab.pipeline import admit

    if not 0 < args.false_alarm < 0.5:
        raise ValueError(f"--false-alarm {args.false_alarm:g}: expected a rate between 0 and "
                         "0.5")
    inspecting = args.action == "inspect"
    admit(args, note_printer(f"fleet {args.action}"),
          outputs=None if inspecting else {"out": "file"},
          registry=db_path(args) if inspecting else None)  # before any work
    if inspecting:
        return _inspect(args)
    return _calibrate(args)


def _inspect(args: argparse.Namespace) -> int:
    from batlab.fleet.cluster import connect
    from batlab.fleet.inspect_fleet import inspect_fleet, retest_jobs
    from batlab.formatting import readable
    from batlab.registry import open_registry

    if not args.folder:
        raise ValueError("fleet inspect: give the folder of SERIAL.uff re-tests")
    progress = progress_printer("fleet inspect")
    jobs = retest_jobs(args.folder)
    db = db_path(args)
    with open_registry(db, create=False):  # missing or damaged: refused before a cluster starts
        pass
    with connect(args.scheduler) as client:
        progress(f"{len(jobs)} re-test(s) on {_describe(client)}")
        out = inspect_fleet(client, db, jobs, args.false_alarm, progress)
    if args.json:
        print(json.dumps(out))
    else:
        for o in out:
            print(o["error"] if "error" in o else readable(o), end="\n\n")
    return 1 if any("error" in o for o in out) else 0


def _calibrate(args: argparse.Namespace) -> int:
    from batlab.fleet.calibrate import BatSpec, default_model, read_bat, summary
    from batlab.fleet.cluster import connect

    if not (args.profile and args.meta and args.n):
        raise ValueError("fleet calibrate: give --profile, --meta and --n")
    if args.n < 1:
        raise ValueError(f"--n {args.n}: at least one clean bat")
    if args.resume and not args.out:
        raise ValueError("fleet calibrate: --resume needs -o, the rows file to resume")
    if args.model is not None and not args.store:
        raise ValueError("fleet calibrate: --model names what --store keeps; give --store")
    progress = progress_printer("fleet calibrate")
    spec = BatSpec(str(args.profile), str(args.meta), args.seed, args.false_alarm)
    serial = read_bat(spec)[2].get("serial")  # a bad file fails here, before any work
    model = (args.model or default_model(spec)) if args.store else None
    if args.store:  # an unusable registry fails here, before hours of work
        from batlab.registry import open_registry, shown

        with open_registry(db_path(args)):
            progress(f"the calibration will be stored in {shown(db_path(args))} as bat model "
                     f"{model}")
    stored = _stored_rows(args, progress)
    t0 = time.perf_counter()
    with connect(args.scheduler) as client:
        cores = sum(client.nthreads().values())
        progress(f"{args.n} clean re-tests of {serial} on {_describe(client)}")
        new = _new_rows(client, spec, args, stored, progress)
    wall = time.perf_counter() - t0
    rows = sorted(stored + new, key=lambda r: r["index"])
    out = summary(rows, spec, serial)
    out["core_s_per_bat"] = wall * cores / len(new) if new else None
    if new:
        cpu = sorted(r["cpu_s"] for r in new)
        progress(f"{wall:.0f} s on {cores} core(s): {out['core_s_per_bat']:.2f} core-s a "
                 f"bat; CPU {sum(cpu) / len(cpu):.2f} s a bat (median {cpu[len(cpu) // 2]:.2f} s)")
    if set(out["codes"]) != {out["code"]}:
        progress("rows judged by other code than this batlab's " + out["code"] + ": "
                 + ", ".join(f"{n} by {c}" for c, n in out["codes"].items()))
    if args.store:
        out["stored"] = _store(args, model, rows, out, progress)
    print(json.dumps(out) if args.json else _words(out))
    return 0


def _store(args: argparse.Namespace, model: str, rows: list[dict], out: dict,
           progress) -> dict:
    """Store the calibration (``fleet.calibrate.store_calibration``); say where."""
    from batlab.fleet.calibrate import store_calibration
    from batlab.registry import open_registry, shown

    with open_registry(db_path(args)) as conn:
        done = store_calibration(conn, model, rows, out)
    progress(f"stored as calibration #{done.id} of bat model {model} (custody record "
             f"#{done.record_seq}) in {shown(db_path(args))}")
    return {"calibration": done.id, "model": model, "record_seq": done.record_seq,
            "db": shown(db_path(args))}


def _stored_rows(args: argparse.Namespace, progress) -> list[dict]:
    """Return the rows ``--resume`` keeps from ``-o``'s file (none without it).

    A last line cut short is taken off the file (atomically), so new rows start on a line of
    their own; every complete line stays, rows beyond ``--n`` included.
    """
    from batlab.fleet.calibrate import drop_cut_line, read_rows

    if not (args.resume and os.path.exists(args.out)):
        return []
    rows, cut = read_rows(args.out, args.n)
    progress(f"{args.out}: {len(rows)} re-test(s) already done"
             + (", a last line cut short left out" if cut else ""))
    if cut:
        drop_cut_line(args.out)
    return rows


def _new_rows(client, spec, args: argparse.Namespace, stored: list[dict],
              progress) -> list[dict]:
    """Inspect the re-tests not in ``stored`` (the last stored one again, first, to check)."""
    from batlab.fleet.calibrate import check_resumed, run_calibration

    done = {r["index"] for r in stored}
    todo = [i for i in range(1, args.n + 1) if i not in done]
    if stored:
        progress(f"re-test {stored[-1]['index']} inspected again: it must agree with its row")
        again = run_calibration(client, spec, [stored[-1]["index"]], progress)[0]
        other_code = check_resumed(args.out, stored[-1], again)
        if other_code:
            progress(other_code)
    if not todo:
        return []
    rows_file = open(args.out, "a" if args.resume else "w") if args.out else None  # noqa: SIM115
    try:
        return run_calibration(client, spec, todo, progress,
                               None if rows_file is None else _row_writer(rows_file))
    finally:
        if rows_file is not None:
            rows_file.close()


def _row_writer(file):
    """Return ``write(row)``: one JSON line in ``file``, flushed (a long run's rows survive)."""
    def write(row: dict) -> None:
        print(json.dumps(row), file=file, flush=True)

    return write


def _describe(client) -> str:
    """Word a cluster: its scheduler and worker threads."""
    return f"{client.scheduler.address} ({sum(client.nthreads().values())} worker thread(s))"


def _words(out: dict) -> str:
    """Word a calibration's summary for a reader."""
    t = out["tail"]
    lines = [f"{out['serial']}: {out['n']} clean re-tests (seed {out['seed']}, false-alarm "
             f"rate {out['false_alarm']:g})",
             f"  called altered: {out['false_alarms']}; inconclusive: {out['inconclusive']}; "
             f"refused: {out['refused']}",
             f"  false-alarm rate below {out['false_alarm_upper95']:.2e} (95 % upper bound, "
             "Clopper-Pearson)"]
    if out.get("core_s_per_bat") is not None:
        lines.append(f"  cost: {out['core_s_per_bat']:.2f} core-s a bat")
    lines.append("  judged by " + ", ".join(f"batlab {c} ({n} re-tests)"
                                            for c, n in out["codes"].items()))
    if out.get("stored"):
        st = out["stored"]
        lines.append(f"  stored: calibration #{st['calibration']} of bat model {st['model']}, "
                     f"custody record #{st['record_seq']}, in {st['db']}")
    if t.get("smallest_p"):
        lines.append("  smallest p: " + ", ".join(f"{r['p']:.2g} (#{r['index']})"
                                                  for r in t["smallest_p"]))
    return "\n".join(lines)
