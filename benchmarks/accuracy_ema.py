"""Accuracy study of the automatic fit on random modal models (the hidden-effect tests, many
more examples): found / invented modes and worst errors by damping class.

    python benchmarks/accuracy_ema.py [--noise 0.005] [--models 40]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

from ema_synthetic import make_test  # noqa: E402

from ema.modal_fit import fit_test  # noqa: E402
from ema.shapes.mac import mac  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--noise", type=float, default=0.005, help="noise RMS / FRF RMS")
    ap.add_argument("--models", type=int, default=40)
    ap.add_argument("--refine", action="store_true", help="maximum-likelihood pole refinement")
    args = ap.parse_args()
    rows, missed, invented = [], 0, 0
    for seed in range(args.models):
        rng = np.random.default_rng(1000 + seed)
        case = make_test(seed, n_modes=int(rng.integers(4, 9)), n_points=int(rng.integers(15, 21)),
                         noise=args.noise, close_ratio=float(rng.uniform(0.01, 0.03)))
        fit = fit_test(case.test, refine=args.refine)
        f = case.model.freq_hz[case.in_band]
        z = case.model.damping_ratio[case.in_band]
        rel = np.abs(fit.freq_hz[None, :] / f[:, None] - 1) if fit.freq_hz.size else None
        idx = (np.argmin(rel, axis=1) if rel is not None else np.full(f.size, -1))
        ok = (idx >= 0) & ((rel[np.arange(f.size), idx] < 0.003) if rel is not None else False)
        missed += int((~ok).sum())
        invented += int(fit.freq_hz.size - np.unique(idx[ok]).size)
        macs = np.diag(mac(fit.real_shapes[:, idx[ok]], case.model.shapes[:, case.in_band][:, ok]))
        for k, j, m in zip(np.flatnonzero(ok), idx[ok], macs, strict=True):
            rows.append((z[k], abs(fit.freq_hz[j] / f[k] - 1),
                         abs(fit.damping_ratio[j] / z[k] - 1), m,
                         abs(fit.freq_hz[j] - f[k]) / fit.freq_std_hz[j]))
    r = np.array(rows)
    how = " refined" if args.refine else ""
    print(f"noise {100 * args.noise:g} %{how}, {args.models} models, {len(r) + missed} modes: "
          f"missed {missed}, invented {invented}")
    for lo, hi in ((0.0, 0.01), (0.01, 0.02), (0.02, 0.031)):
        s = (r[:, 0] >= lo) & (r[:, 0] < hi)
        print(f"zeta {100 * lo:.0f}-{100 * hi:.0f} %: n={s.sum():3d}  max freq err "
              f"{100 * r[s, 1].max():.4f} %  max damping err {100 * r[s, 2].max():.2f} %  "
              f"min MAC {r[s, 3].min():.6f}  max |err|/std {r[s, 4].max():.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
