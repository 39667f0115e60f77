"""Read speed of batlab's UFF reader against pyuff's own, on one typical bat test.

20 FRFs x 6401 lines (0 to 3200 Hz by 0.5 Hz), complex double, ASCII and binary 58.
Prints the best of a few repeats for ``ema.io.uff.read_uff`` and for
``pyuff.UFF(path).read_sets()`` on the same file, and their ratio.

    python benchmarks/bench_uff_read.py
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyuff

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ema.io.frf_data import FrfTest  # noqa: E402
from ema.io.uff import read_uff, write_uff  # noqa: E402
from rigs.modal_model import ModalModel  # noqa: E402

N_POINTS, N_LINES, DF_HZ, REPEATS = 20, 6401, 0.5, 5


def typical_test() -> FrfTest:
    """Roving hammer over 20 points, accelerometer on the last; 2 rigid + 6 bending modes."""
    x = np.linspace(0.0254, 0.81, N_POINTS)
    u = x / 0.84
    shapes = np.stack([np.ones_like(u), u - 0.5]
                      + [np.cos((k + 1.5) * np.pi * u) for k in range(6)], axis=1)
    model = ModalModel([1.8, 5.5, 152, 431, 805, 1270, 1790, 2380],
                       [0.05, 0.05, 0.012, 0.009, 0.007, 0.006, 0.005, 0.005], shapes, x)
    f = np.arange(N_LINES) * DF_HZ
    nodes = np.arange(1, N_POINTS + 1)
    return FrfTest(f, model.accelerance(f, [N_POINTS - 1], np.arange(N_POINTS)),
                   [N_POINTS], nodes, dict(zip(nodes.tolist(), x.tolist(), strict=True)))


def best_of(fn, path: Path) -> float:
    times = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        fn(path)
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    test = typical_test()
    with tempfile.TemporaryDirectory() as tmp:
        print(f"{N_POINTS} FRFs x {N_LINES} lines, best of {REPEATS}")
        print(f"{'form':8s} {'size MB':>8s} {'batlab s':>9s} {'pyuff s':>9s} {'ratio':>7s}")
        for binary in (False, True):
            path = Path(tmp) / f"bench_{'bin' if binary else 'asc'}.uff"
            write_uff(path, test, binary=binary)
            ours = best_of(read_uff, path)
            theirs = best_of(lambda p: pyuff.UFF(str(p)).read_sets(), path)
            form = "binary" if binary else "ASCII"
            size = path.stat().st_size / 1e6
            print(f"{form:8s} {size:8.2f} {ours:9.4f} {theirs:9.4f} {theirs / ours:6.1f}x")


if __name__ == "__main__":
    main()
