"""Run `batlab` commands in this process and spread work over a Dask cluster.

Each bat's files are inspected by the real command (``batlab.cli.main``), as a lab runs it::

    batlab inspect --profile P --meta M --baseline B.uff --retest R.uff [--retest-meta J] --json
    batlab register ... ; batlab inspect --serial S R.uff [--retest-meta J] --json

``--retest-meta`` is passed only when this batlab's inspect knows it. Work is spread over
a Dask cluster (``fleet_map``: a local one sized to the machine, or a running scheduler);
progress goes to stderr.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from batlab.cli import build_parser
from batlab.cli import main as batlab_main


def run_batlab(args: list) -> tuple[int, dict | None, str]:
    """Run one `batlab` command line in this process.

    Parameters
    ----------
    args : list
        The command line after ``batlab`` (items converted with ``str``).

    Returns
    -------
    code : int
        The exit code.
    out : dict or None
        The JSON object printed on stdout (exit 0 only), else None.
    err : str
        The last stderr line ("" if none).
    """
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
    """Return whether this batlab's inspect takes ``--retest-meta``."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return "--retest-meta" in sub.choices["inspect"]._option_string_actions


def inspect_args(paths: dict, serial: str | None = None, db: Path | None = None) -> list:
    """Build the inspect command line for a bat's files.

    Parameters
    ----------
    paths : dict
        The files by name (``field_fleet.write_case``): profile, meta, baseline, retest and
        retest_meta (None: not passed).
    serial : str or None
        None: stateless inspection; else the registered bat's serial.
    db : Path or None
        The registry, with ``serial``.

    Returns
    -------
    list
        The arguments after ``batlab``, ending in ``--json``.
    """
    if serial is None:
        args = ["inspect", "--profile", paths["profile"], "--meta", paths["meta"],
                "--baseline", paths["baseline"], "--retest", paths["retest"]]
    else:
        args = ["inspect", "--serial", serial, paths["retest"], "--db", db]
    if paths.get("retest_meta") and supports_retest_meta():
        args += ["--retest-meta", paths["retest_meta"]]
    return args + ["--json"]


def timed(args: list) -> tuple[dict | None, str, float]:
    """Run a `batlab` command line and time it.

    Returns
    -------
    out : dict or None
        Its JSON output (None on a non-zero exit).
    err : str
        Its last stderr line.
    seconds : float
        Wall time, s.
    """
    t0 = time.perf_counter()
    _, out, err = run_batlab(args)
    return out, err, time.perf_counter() - t0


def _note_line(label: str, done: int, total: int, res, seconds: float) -> str:
    """Word the progress line of a finished item (its first row's kind and status)."""
    first = res[0] if isinstance(res, list) and res else res
    what = f"{first.get('kind')}: {first.get('status')}" if isinstance(first, dict) else ""
    return f"  {label} {done}/{total} ({what}) {seconds:.0f} s"


def fleet_map(fn: Callable, items: Iterable, workers: int | None = None, label: str = "bat",
              scheduler: str | None = None) -> list:
    """Map ``fn`` over ``items`` on a Dask cluster (``batlab.fleet.cluster``).

    Parameters
    ----------
    fn : callable
        A module-level function (sent to the workers by reference).
    items : iterable
        Its arguments, one task each.
    workers : int or None
        The local cluster's worker processes (default: one per core); ignored with
        ``scheduler``.
    label : str
        What an item is, for the progress lines on stderr (one per finished item).
    scheduler : str or None
        A running Dask scheduler's address; None: a local cluster.

    Returns
    -------
    list
        The results in item order.
    """
    from batlab.fleet.cluster import connect, ordered_map

    items = list(items)
    if not items:
        return []
    t0, done = time.perf_counter(), 0

    def note(_: int, res):
        nonlocal done
        done += 1
        print(_note_line(label, done, len(items), res, time.perf_counter() - t0),
              file=sys.stderr, flush=True)
        return res

    with connect(scheduler, workers) as client:
        return ordered_map(client, fn, items, label,
                           lambda line: print(f"  {line}", file=sys.stderr, flush=True), note)


def save_rows(path: str | None, rows: list[dict]) -> None:
    """Write result rows as JSON to ``path`` (nothing when it is None)."""
    if path:
        Path(path).write_text(json.dumps(rows, indent=1, default=float))
