"""Time and peak memory of SEREP + MSSO and of the refinement vs the number of elements.

The paper's corked bat meshed with 33, 100, 330 and 1000 elements; 6 elastic test modes at
34 sensor points (1 in apart, forced to be nodes). Prints a table and the fitted growth
exponent (time ~ e^k). Peak memory is traced Python/numpy allocation (tracemalloc).
Usage: python benchmarks/bench_msso.py [--sizes 33 100 330 1000] [--refine-iter 2]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import tracemalloc

os.environ.setdefault("OMP_NUM_THREADS", "1")  # small dense blocks: threads only contend
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402

sys.path.insert(0, ".")

from updating.correlate.measured import sampled_modes  # noqa: E402
from updating.correlate.pairing import paired_elastic  # noqa: E402
from updating.correlate.serep import serep  # noqa: E402
from updating.model.assembly import build_model  # noqa: E402
from updating.model.material import paper_material  # noqa: E402
from updating.model.modes import model_modes  # noqa: E402
from updating.model.profile import paper_profile  # noqa: E402
from updating.model.sections import Core  # noqa: E402
from updating.model.units import IN_TO_M  # noqa: E402
from updating.msso.expansion import expansion_pass  # noqa: E402
from updating.msso.factors import zero_factors  # noqa: E402
from updating.msso.iterate import refine  # noqa: E402
from updating.msso.skyline import msso_elements  # noqa: E402


def measure(fn):
    tracemalloc.start()
    t0 = time.perf_counter()
    out = fn()
    dt = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return out, dt, peak / 2**20


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[33, 100, 330, 1000])
    ap.add_argument("--refine-iter", type=int, default=2)
    args = ap.parse_args()
    points = np.arange(34) * IN_TO_M
    rows = []
    for ne in args.sizes:
        ref = build_model(paper_profile(), paper_material(), n_elements=ne, stations_m=points)
        cork = build_model(paper_profile(), paper_material(), n_elements=ne, stations_m=points,
                           core=Core(IN_TO_M, 10 * IN_TO_M, 1 / 3, 0.0, IN_TO_M))
        t = model_modes(cork, 8).elastic()
        a = 2 * np.array([ref.node_at(x) for x in points])
        test = sampled_modes(t, a, ref.node_x_m)
        Phi = model_modes(ref).shapes
        idx = paired_elastic(Phi, test.shapes, a, 2)
        E = serep(np.column_stack([Phi[:, :2], Phi[:, idx]]), a).expand(test.shapes)
        _, t_msso, m_msso = measure(lambda: msso_elements(ref, E, test.omega2))  # noqa: B023
        (f1, _, _), t_pass, m_pass = measure(
            lambda: expansion_pass(ref, test, zero_factors(ref.n_elements)))  # noqa: B023
        rr, t_ref, m_ref = measure(lambda: refine(
            ref, test, f1, ("k", "m"), prior_sigma=None, shape_sigma=1e-6,  # noqa: B023
            freq_sigma=1e-7, max_iter=args.refine_iter))
        rows.append((ne, ref.n_dof, t_msso, m_msso, t_pass, m_pass, t_ref / rr.n_iter, m_ref))
        print(f"{ne} elements done", file=sys.stderr)
    print("| elements | DOF | MSSO s | MSSO peak MiB | SEREP+MSSO pass s | pass peak MiB "
          "| refinement s/iter | refinement peak MiB |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:.3f} | {r[3]:.1f} | {r[4]:.3f} | {r[5]:.1f} "
              f"| {r[6]:.3f} | {r[7]:.1f} |")
    e = np.log([r[0] for r in rows])
    for j, name in ((2, "MSSO time"), (3, "MSSO memory"), (4, "pass time"),
                    (6, "refinement time/iter"), (7, "refinement memory")):
        k = np.polyfit(e, np.log([r[j] for r in rows]), 1)[0]
        print(f"{name} grows as e^{k:.2f}")


if __name__ == "__main__":
    main()
