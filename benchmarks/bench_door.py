"""The door: every malformed input of tests/door_cases.py run as a user runs it, and timed.

Registers the sample bat (data_samples/smooth_bat) in a fresh registry, writes every
malformed case (tests/door_cases.py: meta.json, profile.csv, FRF files, retest.json and
options, each tried with every command that reads it) and runs each as a subprocess,
``python -m batlab ...`` (this checkout's code first on PYTHONPATH). A case is *refused at
the door* when it exits 2 with exactly one stderr line that is not a progress line, that
line holds the case's file (or option) and key, stderr holds no Python warning, no file
appeared or vanished under the case folders, and the registry's bytes are unchanged.
Prints each case that is not, the count of those that are, and the wall time to refusal
(median and largest, start-up included). No assertion on time: it depends on the machine.

    python benchmarks/bench_door.py [--only SUBSTRING] [--timeout 300]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.door_cases import SAMPLE, malformed_cases  # noqa: E402

PROGRESS = re.compile(r"^batlab [\w-]+ \[\s*[\d.]+ s\]: ")
WARNING = re.compile(r"Warning\b|warnings\.warn")


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


def _snapshot(root: Path) -> dict[str, str]:
    """Every file under ``root``: its SHA-256 (the registry's bytes among them)."""
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def judge(code: int, err: str, names: tuple[str, ...], before: dict, after: dict) -> str:
    """Return '' when a run is refused at the door, else what is wrong with it."""
    lines = [ln for ln in err.splitlines() if ln.strip() and not PROGRESS.match(ln)]
    why = []
    if code != 2:
        why.append(f"exit {code}")
    if len(lines) != 1:
        why.append(f"{len(lines)} non-progress lines")
    elif missing := [n for n in names if n not in lines[0]]:
        why.append(f"does not name {missing}")
    if WARNING.search(err):
        why.append("warning text")
    if before != after:
        changed = sorted(set(before.items()) ^ set(after.items()))
        why.append(f"files changed: {sorted({c[0] for c in changed})[:3]}")
    return "; ".join(why)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="run the cases whose name holds this")
    ap.add_argument("--timeout", type=float, default=300.0, help="per case, s (default 300)")
    opts = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="batlab-door-") as tmp:
        root = Path(tmp)
        lab = root / "lab"
        lab.mkdir()
        db = lab / "registry.sqlite"
        subprocess.run([sys.executable, "-m", "batlab", "register", "--profile",
                        str(SAMPLE / "profile.csv"), "--meta", str(SAMPLE / "meta.json"),
                        "--baseline", str(SAMPLE / "baseline.uff"), "--db", str(db)],
                       env=_env(), check=True, capture_output=True)
        cases = [c for c in malformed_cases(root / "cases", db) if opts.only in c.name]
        refused, times, wrong = 0, [], []
        for case in cases:
            before = _snapshot(root)
            t0 = time.perf_counter()
            try:
                res = subprocess.run([sys.executable, "-m", "batlab", *case.argv], env=_env(),
                                     capture_output=True, text=True, timeout=opts.timeout,
                                     errors="replace")
                code, err = res.returncode, res.stderr
            except subprocess.TimeoutExpired:
                code, err = -1, "timeout"
            took = time.perf_counter() - t0
            why = judge(code, err, case.names, before, _snapshot(root))
            if why:
                last = err.strip().splitlines()[-1][:160] if err.strip() else ""
                wrong.append(f"{case.name:50s} {took:5.1f} s  {why}  | {last}")
            else:
                refused += 1
                times.append(took)
        for line in wrong:
            print(line)
        print(f"\n{refused} of {len(cases)} malformed inputs refused at the door"
              + (f"; time to refusal median {statistics.median(times):.2f} s, largest "
                 f"{max(times):.2f} s (start-up included)" if times else ""))


if __name__ == "__main__":
    main()
