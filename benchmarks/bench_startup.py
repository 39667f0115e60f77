"""Start-up time of the ``batlab`` command line: how long before it does anything.

Runs ``python -m batlab --version``, ``--help`` and ``inspect --help`` as subprocesses
(this checkout's code first on PYTHONPATH), N times each, and prints the median, min and
max wall time, the number of modules imported (``python -X importtime``) and which heavy
ones among them (numpy, scipy.signal, pandas, matplotlib, pyserial, pyuff). No assertion on
time: the numbers depend on the machine and its load.

    python benchmarks/bench_startup.py [-n RUNS]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASES = (("--version",), ("--help",), ("inspect", "--help"))
HEAVY = ("numpy", "scipy", "scipy.signal", "pandas", "matplotlib", "serial", "pyuff")


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


def wall_times(args: tuple[str, ...], runs: int) -> list[float]:
    """Wall time (s) of ``runs`` runs of ``python -m batlab ARGS``."""
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "batlab", *args], env=_env(), check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        times.append(time.perf_counter() - t0)
    return times


def imported(args: tuple[str, ...]) -> list[str]:
    """Names of the modules one run of ``python -m batlab ARGS`` imports."""
    res = subprocess.run([sys.executable, "-X", "importtime", "-m", "batlab", *args],
                         env=_env(), check=True, stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True)
    return [line.rsplit("|", 1)[1].strip() for line in res.stderr.splitlines()
            if line.startswith("import time:") and "[us]" not in line]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", "--runs", type=int, default=10, help="runs per command (default 10)")
    runs = ap.parse_args().runs
    print(f"{'command':<24} {'median s':>8} {'min s':>7} {'max s':>7} {'modules':>7}  heavy")
    for args in CASES:
        t = wall_times(args, runs)
        mods = imported(args)
        heavy = [m for m in HEAVY if m in mods]
        print(f"{'batlab ' + ' '.join(args):<24} {statistics.median(t):8.3f} {min(t):7.3f} "
              f"{max(t):7.3f} {len(mods):7d}  {', '.join(heavy) or '-'}")


if __name__ == "__main__":
    main()
