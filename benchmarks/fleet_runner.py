"""Run virtual bats through the real command path and read the verdicts (fleet benchmarks).

Used by bench_false_alarm.py and bench_detection.py. Each bat's files are written as a lab
hands them over (``updating.simulate.field_fleet.write_case``) and inspected by the real
command, in this process (``batlab.cli.main``):

    batlab inspect --profile P --meta M --baseline B.uff --retest R.uff [--retest-meta J] --json
    batlab register ... ; batlab inspect --serial S R.uff [--retest-meta J] --json

``--retest-meta`` is passed only when the installed inspect knows it. The three-way verdict
is read from ``status`` when the output has it, else from ``altered`` (the two-way output of
older versions); a non-zero exit is a refusal ("refused", with its stderr line). Work is
spread over at most 2 processes; progress goes to stderr.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # small matrices: threads only contend
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import multiprocessing  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable, Iterable  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from batlab.cli import main as batlab_main  # noqa: E402

STATUSES = ("not_altered", "inconclusive", "altered", "refused", "error")
"""Verdicts, a refusal (non-zero exit), and "error": the benchmark itself failed on that bat
(the simulation, not batlab), reported, never counted as a verdict."""
MAX_WORKERS = 2


def run_batlab(args: list) -> tuple[int, dict | None, str]:
    """(exit code, the JSON object on stdout or None, last stderr line)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = batlab_main([str(a) for a in args])
        except SystemExit as exc:  # argparse
            code = int(exc.code or 0)
    lines = err.getvalue().strip().splitlines()
    text = out.getvalue().strip()
    return code, (json.loads(text) if code == 0 and text else None), (lines[-1] if lines else "")


def supports_retest_meta() -> bool:
    """Whether this batlab's inspect takes ``--retest-meta``."""
    from batlab.commands import inspect as cmd

    p = argparse.ArgumentParser()
    cmd.add_arguments(p)
    return "--retest-meta" in p._option_string_actions


def verdict_status(out: dict | None) -> str:
    """"altered", "not_altered" or "inconclusive" (from ``status``, else ``altered``);
    "refused" when there is no output."""
    if out is None:
        return "refused"
    if "status" in out:
        return str(out["status"])
    if out.get("altered") is None:
        return "inconclusive"
    return "altered" if out["altered"] else "not_altered"


def inspect_args(paths: dict, serial: str | None = None, db: Path | None = None) -> list:
    """The inspect command line for a bat's files (stateless, or registry with ``serial``)."""
    if serial is None:
        args = ["inspect", "--profile", paths["profile"], "--meta", paths["meta"],
                "--baseline", paths["baseline"], "--retest", paths["retest"]]
    else:
        args = ["inspect", "--serial", serial, paths["retest"], "--db", db]
    if paths.get("retest_meta") and supports_retest_meta():
        args += ["--retest-meta", paths["retest_meta"]]
    return args + ["--json"]


def verdict_row(out: dict | None, err: str, seconds: float, truth: dict) -> dict:
    """One result row: what was hidden, what came back, how long it took."""
    row = {"serial": truth.get("serial"), "kind": truth["kind"],
           "integrity": truth.get("integrity"), "expected": truth["expected"],
           "status": verdict_status(out), "confidence": None if out is None else
           out.get("confidence"), "seconds": round(seconds, 2), "error": err if out is None
           else None, "truth": truth}
    if out is not None:
        row.update(region_in=out.get("region_in"), core_diameter_in=out.get("core_diameter_in"),
                   fill_density_ratio=out.get("fill_density_ratio"),
                   reasons=out.get("reasons"))
    return row


def timed(args: list) -> tuple[dict | None, str, float]:
    t0 = time.perf_counter()
    _, out, err = run_batlab(args)
    return out, err, time.perf_counter() - t0


def pool_map(fn: Callable, items: Iterable, workers: int, label: str) -> list:
    """``fn`` over ``items`` in at most MAX_WORKERS processes, results in item order;
    one progress line per item on stderr."""
    items = list(items)
    workers = max(1, min(workers, MAX_WORKERS, len(items) or 1))
    results = [None] * len(items)
    t0 = time.perf_counter()

    def note(i, res):
        results[i] = res
        done = sum(r is not None for r in results)
        first = res[0] if isinstance(res, list) and res else res
        what = f"{first.get('kind')}: {first.get('status')}" if isinstance(first, dict) else ""
        print(f"  {label} {done}/{len(items)} ({what}) {time.perf_counter() - t0:.0f} s",
              file=sys.stderr, flush=True)

    if workers == 1:
        for i, item in enumerate(items):
            note(i, fn(item))
        return results
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(workers) as pool:
        for i, res in pool.imap_unordered(_indexed, [(fn, i, it) for i, it in enumerate(items)]):
            note(i, res)
    return results


def _indexed(job):
    fn, i, item = job
    return i, fn(item)


def count_table(groups: dict[str, list[dict]]) -> str:
    """Markdown: per group, how many bats got each status, and the median inspect time."""
    lines = ["| group | bats | not_altered | inconclusive | altered | refused | error | median s |",
             "|---|---|---|---|---|---|---|---|"]
    for name, rows in groups.items():
        c = {s: sum(r["status"] == s for r in rows) for s in STATUSES}
        t = sorted(r["seconds"] for r in rows)
        med = t[len(t) // 2] if t else float("nan")
        lines.append(f"| {name} | {len(rows)} | {c['not_altered']} | {c['inconclusive']} | "
                     f"{c['altered']} | {c['refused']} | {c['error']} | {med:.1f} |")
    return "\n".join(lines)


def save_rows(path: str | None, rows: list[dict]) -> None:
    if path:
        Path(path).write_text(json.dumps(rows, indent=1, default=float))
