"""Errors of one MSSO pass vs batlab's refinement on the paper's corked bat with noisy modes.

For each shape-noise level (frequency noise 0.05 %) and number of modes, ``--draws`` noisy
copies of the corked bat's modes at the 34 translational DOFs are updated; the table gives
the mean and RMS relative errors of the element-24..32 means of alpha and beta, of the core
diameter and fill ratio read from the factors, and how often the region is found within one
element of the truth. Usage: python benchmarks/msso_noise_table.py [--draws 50] [--jobs 2]
"""

from __future__ import annotations

import argparse
import os
import sys
from concurrent.futures import ProcessPoolExecutor

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one BLAS thread per worker process
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402

sys.path.insert(0, ".")

from updating.correlate.measured import sampled_modes, with_noise  # noqa: E402
from updating.model.assembly import build_model  # noqa: E402
from updating.model.material import paper_material  # noqa: E402
from updating.model.modes import model_modes  # noqa: E402
from updating.model.profile import paper_profile  # noqa: E402
from updating.model.sections import Core  # noqa: E402
from updating.model.units import IN_TO_M  # noqa: E402
from updating.msso.core_reading import changed_region, core_from_factors  # noqa: E402
from updating.msso.update import update_elements  # noqa: E402

TRUE = {"alpha": -(2 / 3) / 2.7**2, "beta": -(1 / 2.7) ** 4, "d": 1.0, "r": 1 / 3}
CORE = slice(23, 32)


def one(args):
    m, noise, seed = args
    ref = build_model(paper_profile(), paper_material())
    cork = build_model(paper_profile(), paper_material(),
                       core=Core(IN_TO_M, 10 * IN_TO_M, 1 / 3, 0.0, IN_TO_M))
    t = model_modes(cork, m + 2).elastic()
    a = cork.translational_dofs
    test = with_noise(sampled_modes(t, a, cork.node_x_m), noise, 5e-4,
                      np.random.default_rng(seed))
    u = update_elements(ref, test.freq_hz, test.shapes, a, freq_sigma=5e-4, shape_sigma=noise)
    out = {}
    for name, f in (("one_pass", u.one_pass), ("refined", u.factors)):
        el, _ = changed_region(f.beta_bend, f.alpha_trans)
        found = el.size > 0 and abs(el[0] - 23) <= 1 and abs(el[-1] - 31) <= 1
        d, r = core_from_factors(ref, el, f.beta_bend, f.alpha_trans) if el.size else (np.nan,) * 2
        out[name] = [f.alpha_trans[CORE].mean() / TRUE["alpha"] - 1,
                     f.beta_bend[CORE].mean() / TRUE["beta"] - 1,
                     d / IN_TO_M / TRUE["d"] - 1, r / TRUE["r"] - 1, float(found)]
    return m, noise, out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--draws", type=int, default=50)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--modes", type=int, nargs="+", default=[4, 5, 6])
    args = ap.parse_args()
    jobs = [(m, nz, 1000 * m + s + int(nz * 1e5)) for nz in (1e-3, 1e-2) for m in args.modes
            for s in range(args.draws)]
    res: dict = {}
    with ProcessPoolExecutor(args.jobs) as ex:
        for k, (m, nz, out) in enumerate(ex.map(one, jobs, chunksize=2), 1):
            for name, v in out.items():
                res.setdefault((nz, m, name), []).append(v)
            if k % 20 == 0:
                print(f"{k}/{len(jobs)}", file=sys.stderr)
    print("| shape noise | modes | method | alpha err mean / rms | beta err mean / rms "
          "| d err mean / rms | r err mean / rms | region found |")
    print("|---|---|---|---|---|---|---|---|")
    for (nz, m, name), rows in sorted(res.items()):
        v = np.array(rows)
        cells = []
        for j in range(4):
            col = v[:, j][np.isfinite(v[:, j])]
            cells.append(f"{100 * col.mean():+.1f} % / {100 * np.sqrt(np.mean(col**2)):.1f} %"
                         if col.size else "n/a")
        print(f"| {100 * nz:g} % | {m} | {name} | " + " | ".join(cells)
              + f" | {100 * v[:, 4].mean():.0f} % |")


if __name__ == "__main__":
    main()
