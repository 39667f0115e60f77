"""A modal (Ritz) reduction for the inspection's eigen-problems: how accurate, how fast.

Issue 51 lists "a modal reduction for the Jacobians" among the ways to fewer costly
eigen-solutions. This records the stiffness and mass of every state the inspection of the
demo's corked re-test solves (``ChangePredictor.state``: the fits' residuals and
Jacobians, the kinds' families, the leave-outs), then solves each again on a reduced basis T
(the Rayleigh-Ritz problem T^T K T y = lambda T^T M T y, its lowest ``n_solve`` modes) and
prints, per basis size r, the time a state against the full dense solve and the largest
relative error of the elastic frequencies and 1 - MAC of their shapes (M-weighted), for two
bases: the first state's lowest r modes (one basis for the whole inspection), and the
previous state's (a basis recycled along the fits). The frequencies' own noise in that test
is printed beside them: an error well below it (0.1 of it, say) would leave F alone.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_modal_reduction.py [--states 400]

Nothing is adopted from here unless the errors are; docs/results/speed.md has the table.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("BATLAB_FIT_WORKERS", "1")  # every state solved in this process

import argparse  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy.linalg  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import updating.inspect.model as change_model  # noqa: E402

ELASTIC_FROM = 2
"""The lowest two modes are the rigid-body ones on the bungees (bounce and pitch)."""


def record_states(limit: int) -> tuple[list[tuple[np.ndarray, np.ndarray]], int, np.ndarray]:
    """Inspect the demo's corked re-test in this process; every state's (K, M) it solved.

    Returns the states (at most ``limit``), ``n_solve`` and the verdict's relative frequency
    noise per paired mode.
    """
    import batlab.pipeline as pipeline
    from batlab.registry import open_registry

    states: list[tuple[np.ndarray, np.ndarray]] = []
    solve = change_model.full_modes

    def recording(K, M):
        if len(states) < limit:
            states.append((K.copy(), M.copy()))
        return solve(K, M)

    with tempfile.TemporaryDirectory(prefix="bench-reduction-") as tmp:
        subprocess.run([sys.executable, "-m", "batlab", "demo", "--out", tmp], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        change_model.full_modes = recording
        try:
            with open_registry(Path(tmp) / "registry.sqlite", create=False) as conn:
                result = pipeline.inspect_registered(conn, "DEMO-34A", Path(tmp) / "retest.uff",
                                                     0.01, with_map=False)
        finally:
            change_model.full_modes = solve
    fit = result.verdict.details.fit
    n_solve = len(result.verdict.modes) + 6
    return states, n_solve, np.asarray(fit.freq_noise_rel)


def _errors(K, M, T, full, m) -> tuple[float, float]:
    """(largest elastic frequency error, largest 1 - MAC) of the reduced solve on T."""
    lam, y = scipy.linalg.eigh(T.T @ K @ T, T.T @ M @ T, subset_by_index=[0, m - 1])
    lam_f, v_f = full[0][:m], full[1][:, :m]
    el = slice(ELASTIC_FROM, m)
    f_err = np.max(np.abs(np.sqrt(lam[el] / lam_f[el]) - 1))
    phi = T @ y[:, el]
    cross = np.sum(phi * (M @ v_f[:, el]), axis=0) ** 2
    mac = cross / (np.sum(phi * (M @ phi), axis=0) * np.sum(v_f[:, el] * (M @ v_f[:, el]), axis=0))
    return float(f_err), float(1 - np.min(mac))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=400, help="states recorded (the first ones)")
    ap.add_argument("--sizes", type=int, nargs="+", default=[16, 24, 32, 48, 64, 96])
    args = ap.parse_args()
    states, m, noise = record_states(args.states)
    print(f"{len(states)} states of {states[0][0].shape[0]} DOF, n_solve {m}; the paired "
          f"frequencies' noise {noise.min():.1e}-{noise.max():.1e} (relative)\n")
    t0 = time.perf_counter()
    full = [scipy.linalg.eigh(K, M) for K, M in states]
    t_full = (time.perf_counter() - t0) / len(states)
    first = full[0][1]
    print("| basis | r | ms a state (full: %.2f) | elastic freq error: median | max | "
          "1 - MAC max |" % (1e3 * t_full))
    print("|---|---|---|---|---|---|")
    for name in ("the first state's modes", "the previous state's modes"):
        for r in args.sizes:
            rows, t = [], 0.0
            for i, (K, M) in enumerate(states[1:], start=1):
                T = (first if name.startswith("the first") else full[i - 1][1])[:, :r]
                t1 = time.perf_counter()
                scipy.linalg.eigh(T.T @ K @ T, T.T @ M @ T, subset_by_index=[0, m - 1])
                t += time.perf_counter() - t1
                rows.append(_errors(K, M, T, full[i], m))
            e = np.array(rows)
            print(f"| {name} | {r} | {1e3 * t / len(rows):.3f} | {np.median(e[:, 0]):.1e} | "
                  f"{e[:, 0].max():.1e} | {e[:, 1].max():.1e} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
