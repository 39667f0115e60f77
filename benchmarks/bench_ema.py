"""Benchmark: automatic batlab EMA vs sdypy-EMA (LSCF + LSFD, given the true frequencies).

Bat-like roving-hammer test: 17 impact points, one accelerometer near the barrel end,
0-3200 Hz at 0.5 Hz (6401 lines), free-free beam bending modes at ~150, 560, 980, 1960 and
2650 Hz with 0.5-1.5 % damping, two suspension modes below 10 Hz, complex Gaussian noise of
0.5 % of each FRF's RMS. Both tools fit the same FRFs in one process; batlab picks its poles
itself, sdypy-EMA is handed the true natural frequencies to pick the nearest stable poles.

    python benchmarks/bench_ema.py [--seeds 5] [--order 50]

Prints per-mode frequency / damping / MAC / scale errors for both, and the time ratio.
"""

from __future__ import annotations

import os

# Both tools run single-threaded BLAS: on a shared 2-core machine OpenBLAS threads contend and
# turn 2 ms factorisations into 200 ms ones, which would measure the machine, not the method.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import io  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ema.io.frf_data import FrfTest  # noqa: E402
from ema.modal_fit import fit_test  # noqa: E402
from ema.shapes.mac import mac  # noqa: E402
from rigs.modal_model import ModalModel  # noqa: E402

BETA_L = np.array([4.7300, 7.8532, 10.9956, 14.1372, 17.2788])
FREQ_HZ = np.array([150.0, 560.0, 980.0, 1960.0, 2650.0])
DAMPING = np.array([0.005, 0.007, 0.009, 0.012, 0.015])
LENGTH_M, MASS_KG = 0.86, 0.9


def bat_model(n_points: int = 17) -> ModalModel:
    """Free-free beam shapes (mass-normalised for a uniform 0.9 kg beam) at the bat's modes."""
    x = np.linspace(0.02, 0.84, n_points)
    u = x / LENGTH_M
    shapes = []
    for bl in BETA_L:
        s = (np.cosh(bl) - np.cos(bl)) / (np.sinh(bl) - np.sin(bl))
        shape = np.cosh(bl * u) + np.cos(bl * u) - s * (np.sinh(bl * u) + np.sin(bl * u))
        shapes.append(shape / np.sqrt(MASS_KG))  # int(shape^2) dx / L = 1 for these
    rb = np.stack([np.ones_like(x) / np.sqrt(MASS_KG),
                   (x - 0.5) / np.sqrt(MASS_KG * LENGTH_M**2 / 12)], axis=1)
    return ModalModel(np.r_[3.5, 7.0, FREQ_HZ], np.r_[0.03, 0.03, DAMPING],
                      np.hstack([rb, np.stack(shapes, axis=1)]), x)


def make_test(seed: int, noise: float = 0.005) -> tuple[FrfTest, ModalModel, int]:
    model = bat_model()
    n = model.x_m.size
    drive = n - 2
    freq = np.arange(6401) * 0.5
    h = model.accelerance(freq, [drive], np.arange(n))
    rng = np.random.default_rng(seed)
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=0, keepdims=True))
    white = rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)
    h = h + noise * rms * white / 2**0.5
    nodes = np.arange(1, n + 1)
    x = dict(zip(nodes.tolist(), model.x_m.tolist(), strict=True))
    return FrfTest(freq, h, nodes[[drive]], nodes, x), model, drive


def run_batlab(test: FrfTest, refine: bool = False):
    fit = fit_test(test, refine=refine)
    return fit.freq_hz, fit.damping_ratio, fit.real_shapes


def run_sdypy(test: FrfTest, drive: int, order: int):
    from sdypy import EMA

    m = EMA.Model(frf=test.frf[:, 0, :].T, freq=test.freq_hz, lower=20, upper=3200,
                  pol_order_high=order, frf_form="accelerance", driving_point=drive)
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        m.get_poles(show_progress=False)
        m.select_closest_poles(list(FREQ_HZ))
        m.get_constants(whose_poles="own")
    # sdypy scales phi = A / sqrt(A_dd), missing the factor sqrt(2 i w_d) of the real-mode
    # convention; report both its raw scale and the corrected one
    wd = 2 * np.pi * np.asarray(m.nat_freq) * np.sqrt(1 - np.asarray(m.nat_xi) ** 2)
    raw = m.phi
    corrected = raw * np.sqrt(2j * wd)[None, :]
    return np.asarray(m.nat_freq), np.asarray(m.nat_xi), raw, corrected


def errors(f, z, shapes, model: ModalModel):
    ft, zt, st = model.freq_hz[2:], model.damping_ratio[2:], model.shapes[:, 2:]
    if f.size != ft.size:
        return None
    real = np.real(shapes * np.exp(-1j * np.angle(np.sum(shapes**2, axis=0)) / 2)[None, :])
    real = real * np.sign(np.sum(real * st, axis=0))[None, :]
    return dict(
        freq=np.abs(f / ft - 1),
        damp=np.abs(z / zt - 1),
        mac=np.diag(mac(shapes, st)),
        scale=np.linalg.norm(real - st, axis=0) / np.linalg.norm(st, axis=0),
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--order", type=int, default=50, help="sdypy-EMA pol_order_high")
    args = ap.parse_args()
    run_batlab(make_test(99)[0])  # warm-up (imports, caches) for both tools
    run_sdypy(*make_test(99)[::2], args.order)
    rows = {"batlab": [], "batlab --refine": [], "sdypy": [], "sdypy (scale corrected)": []}
    times = {"batlab": [], "batlab --refine": [], "sdypy": []}
    for seed in range(args.seeds):
        test, model, drive = make_test(seed)
        t0 = time.perf_counter()
        f, z, s = run_batlab(test)
        times["batlab"].append(time.perf_counter() - t0)
        rows["batlab"].append(errors(f, z, s, model))
        t0 = time.perf_counter()
        f, z, s = run_batlab(test, refine=True)
        times["batlab --refine"].append(time.perf_counter() - t0)
        rows["batlab --refine"].append(errors(f, z, s, model))
        t0 = time.perf_counter()
        f2, z2, raw, corr = run_sdypy(test, drive, args.order)
        times["sdypy"].append(time.perf_counter() - t0)
        rows["sdypy"].append(errors(f2, z2, raw, model))
        rows["sdypy (scale corrected)"].append(errors(f2, z2, corr, model))
    print(f"bat-like test: 17 FRFs x 6401 lines, 0.5 % noise, {args.seeds} noise seeds; "
          f"sdypy-EMA pol_order_high={args.order}, given the true frequencies")
    print(f"{'tool':26s} {'found':>5s} {'max freq err %':>15s} {'max damp err %':>15s} "
          f"{'min MAC':>10s} {'max scale err %':>16s}")
    for name, res in rows.items():
        ok = [r for r in res if r is not None]
        if not ok:
            print(f"{name:26s} {0:>5d}")
            continue
        cat = {k: np.concatenate([r[k] for r in ok]) for k in ok[0]}
        print(f"{name:26s} {len(ok):>2d}/{len(res):<2d} {100 * cat['freq'].max():15.5f} "
              f"{100 * cat['damp'].max():15.3f} {cat['mac'].min():10.6f} "
              f"{100 * cat['scale'].max():16.3f}")
    tb, ts = np.median(times["batlab"]), np.median(times["sdypy"])
    tr = np.median(times["batlab --refine"])
    print(f"median time: batlab {tb:.3f} s (automatic), batlab --refine {tr:.3f} s, "
          f"sdypy-EMA {ts:.3f} s (guided); sdypy / batlab = {ts / tb:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
