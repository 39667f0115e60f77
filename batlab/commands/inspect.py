"""`batlab inspect`: the lab's verdict on a re-test of a bat (../shared/CONTRACT.md).

Two forms, the same verdict:
    batlab inspect --profile P --meta M --baseline B.uff --retest R.uff
                   [--retest-meta retest.json] [--json]                        (stateless)
    batlab inspect --serial S R.uff [--retest-meta retest.json] [--db PATH] [--json]
                                                               (registered bat; stored)
"""

from __future__ import annotations

import json

from batlab.cli_support import add_db_argument, db_path, progress_printer

HELP = "inspect a re-test of a bat for alteration (stateless, or against the registry)"


def add_arguments(p) -> None:
    p.add_argument("retest_file", nargs="?", default=None,
                   help="re-test file (the registry form: --serial S R.uff)")
    p.add_argument("--serial", default=None, help="a registered bat's serial number")
    p.add_argument("--profile", default=None, help="profile.csv (stateless form)")
    p.add_argument("--meta", default=None, help="meta.json (stateless form)")
    p.add_argument("--baseline", default=None, help="baseline test file (stateless form)")
    p.add_argument("--retest", default=None, help="re-test file")
    p.add_argument("--retest-meta", default=None, metavar="RETEST_JSON",
                   help="retest.json: the re-test's weight_lb, accelerometer_mass_g, "
                        "temperature_c, tested_on (every key optional)")
    p.add_argument("--false-alarm", type=float, default=0.01,
                   help="false-alarm rate of the decision (default 0.01)")
    p.add_argument("--report", default=None, metavar="DIR",
                   help="write an HTML report to DIR/index.html")
    add_db_argument(p)
    p.add_argument("--json", action="store_true",
                   help="print the verdict as one JSON object on stdout")


def _retest_path(args) -> str:
    if args.retest and args.retest_file and args.retest != args.retest_file:
        raise ValueError("give the re-test once (--retest R.uff or a positional R.uff)")
    path = args.retest or args.retest_file
    if not path:
        raise ValueError("no re-test file given (--retest R.uff)")
    return path


def readable(out: dict) -> str:
    """The contract dict as a short verdict for a person."""
    conf = out.get("confidence")
    word = {"altered": "ALTERED", "not_altered": "not altered",
            "inconclusive": "INCONCLUSIVE (no verdict)"}[out["status"]]
    head = f"{out['serial']}: {word}"
    if conf is not None and out["status"] != "inconclusive":
        head += f" (confidence {conf:.3f}, false-alarm rate {out.get('false_alarm_rate', 0):g})"
    lines = [head] + [f"  - {r}" for r in out.get("reasons", [])]
    if out["altered"]:
        if out["region_in"]:
            a, b = out["region_in"]
            lines.append(f"  altered region {a:.1f} to {b:.1f} in from the knob end")
        if out["core_diameter_in"] is not None:
            lines.append(f"  core diameter {out['core_diameter_in']:.2f} in")
        if out["fill_density_ratio"] is not None:
            lines.append(f"  fill density / wood density {out['fill_density_ratio']:.2f}")
    els = out["elements"]
    if any(e["alpha"] or e["beta"] for e in els):
        big = max(els, key=lambda e: abs(e["alpha"]) + abs(e["beta"]))
        lines.append(f"  {len(els)} elements; largest change at {big['x0_in']:.1f}-"
                     f"{big['x1_in']:.1f} in: alpha {big['alpha']:+.4f}, beta {big['beta']:+.4f}")
    return "\n".join(lines)


def run(args) -> int:
    from batlab import pipeline
    from batlab.registry import open_registry

    progress = progress_printer("inspect")
    retest = _retest_path(args)
    if not 0 < args.false_alarm < 0.5:
        raise ValueError("--false-alarm must be between 0 and 0.5")
    stateless = (args.profile, args.meta, args.baseline)
    if args.serial:
        if any(stateless):
            raise ValueError("--serial takes the bat from the registry: drop --profile, --meta "
                             "and --baseline")
        with open_registry(db_path(args), create=False) as conn:
            result = pipeline.inspect_registered(conn, args.serial, retest, args.false_alarm,
                                                 refit_baseline=bool(args.report),
                                                 progress=progress,
                                                 retest_meta_path=args.retest_meta)
            report = _report(args, result, progress)
            stored = pipeline.store_inspection(conn, result, retest, report)
            progress(f"stored as inspection #{stored.id} of {result.serial}")
    else:
        if not all(stateless):
            raise ValueError("give --serial S, or all of --profile, --meta and --baseline")
        result = pipeline.inspect_files(args.profile, args.meta, args.baseline, retest,
                                        args.false_alarm, progress, args.retest_meta)
        _report(args, result, progress)
    out = pipeline.contract_dict(result.serial, result.verdict)
    print(json.dumps(out) if args.json else readable(out), flush=True)
    return 0


def _report(args, result, progress) -> str | None:
    if not args.report:
        return None
    from batlab.report import write_report

    progress("writing the report")
    path = write_report(args.report, result)
    progress(f"report: {path}")
    return str(path)
