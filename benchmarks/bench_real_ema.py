"""Benchmark on real measured FRFs: batlab's automatic fit vs sdypy-EMA (LSCF + LSFD).

Data: data_samples/real (see its README): the pyuff beam measurement (1 accelerometer x 3
impacts, 0-1000 Hz at 1 Hz) and its subsets (one FRF, two nodes, no driving point), and the
vibration_toolbox analyser exports (one noisy FRF each, 0-500 Hz at 0.3125 Hz; case2 also at
--min-snr 2, where batlab's default finds nothing), and two generated sets of the characters
no licensed public set was found for (``tests/ema_synthetic.make_character_test``): a
tool-holder-like test (900-3000 Hz, 3-6 % damping, peaks moving 2 % between the points, a
force-spectrum null at 2560 Hz beside the 6 %-damped 2.6 kHz mode) and a wheel-like one (a
weak, well-separated 2.07 kHz mode at about 9 x the noise). Each row counts the modes of the
hand analysis (docs/ema.md; for the generated sets, the true modes) that each tool finds
within 1 %. batlab
picks its poles itself. sdypy-EMA needs the frequencies to look near: it is run twice, handed
(a) the sum-MIF peaks of the same FRFs (what a user reads off the plot,
``ema.poles.mif.pick_peaks``: an independent count) and (b) batlab's frequencies (to compare
the estimates mode by mode); it picks its nearest stable poles. Both fit the same band (20 Hz
to the last line) in one process, single-threaded BLAS. sdypy-EMA returns 0 Hz where it has
no stable pole near a frequency asked: those are not counted.

    python benchmarks/bench_real_ema.py [--order 50] [--repeat 3]

Prints, per data set: modes found by each, the largest frequency and damping differences
between them over the modes both found, the smallest MAC between their shapes (complex, at
the impact nodes; '-' with one node), and the time ratio (median of --repeat runs).
"""

from __future__ import annotations

import os

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

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ema.io.frf_data import FrfTest  # noqa: E402
from ema.io.frf_io import read_test  # noqa: E402
from ema.modal_fit import fit_test  # noqa: E402
from ema.shapes.mac import mac  # noqa: E402

sys.path.insert(0, str(ROOT / "tests"))
from ema_synthetic import make_character_test  # noqa: E402

REAL = ROOT / "data_samples" / "real"
# the hand analysis: modes a person reads off each set (docs/ema.md says how), Hz
BEAM = (51.52, 142.18, 278.67, 460.40, 687.17, 958.53)
# (name, file or generator, band Hz, batlab min_snr or None for the default, hand modes)
SETS = [("pyuff beam, 3 FRFs", "pyuff_measurement/test.uff", (20.0, 1000.0), None, BEAM),
        ("pyuff beam, two nodes", "pyuff_measurement/two_nodes.uff", (20.0, 1000.0), None,
         BEAM),
        ("pyuff beam, one FRF", "pyuff_measurement/one_frf.uff", (20.0, 1000.0), None, BEAM),
        ("pyuff beam, no driving point", "pyuff_measurement/no_driving_point.uff",
         (20.0, 1000.0), None, BEAM),
        ("vibration_toolbox case1", "vibration_toolbox/case1.uff", (20.0, 500.0), None,
         (212.09,)),
        ("vibration_toolbox case2", "vibration_toolbox/case2.uff", (20.0, 500.0), None,
         (192.59,)),
        ("vibration_toolbox case2, --min-snr 2", "vibration_toolbox/case2.uff", (20.0, 500.0),
         2.0, (192.59,)),
        ("holder-like (synthetic, 6 % at 2.6 kHz, force null)", "holder", (20.0, 3200.0),
         None, (950.0, 1250.0, 1900.0, 2600.0, 2950.0)),
        ("wheel-like (synthetic, weak 2.07 kHz)", "wheel", (20.0, 3200.0), None,
         (420.0, 1150.0, 2070.0, 2800.0))]
# the generated sets' true modes are the hand analysis (tests/test_ema_support.py)
GENERATED = {
    "holder": lambda: make_character_test(
        1, [950, 1250, 1900, 2600, 2950], [0.03, 0.03, 0.03, 0.06, 0.03], [1, 1, 1, 1, 1],
        shift=0.02, coherence_dip_hz=2560),
    "wheel": lambda: make_character_test(
        100, [420, 1150, 2070, 2800], [0.002, 0.003, 0.004, 0.003], [1, 1, 0.12, 1]),
}
HAND_TOL = 0.01  # a hand-analysis mode is found when a fitted one lies within 1 %


def hand_found(freq_hz: np.ndarray, hand_hz: tuple[float, ...]) -> int:
    """Count the hand-analysis modes that have a fitted mode within ``HAND_TOL``."""
    f = np.asarray(freq_hz, dtype=float)
    return sum(bool(f.size and np.min(np.abs(f / h - 1)) < HAND_TOL) for h in hand_hz)


def run_sdypy(test: FrfTest, peaks_hz: np.ndarray, order: int, band: tuple[float, float]):
    """(freq, damping, complex shapes) by sdypy-EMA given the peak frequencies."""
    from sdypy import EMA

    if not len(peaks_hz):
        return np.zeros(0), np.zeros(0), np.zeros((0, 0))
    try:
        drive = int(test.driving_point[1])
    except ValueError:
        drive = None
    m = EMA.Model(frf=test.frf[:, 0, :].T, freq=test.freq_hz, lower=band[0], upper=band[1],
                  pol_order_high=order, frf_form="accelerance", driving_point=drive)
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()), \
            contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")
        m.get_poles(show_progress=False)
        m.select_closest_poles(list(peaks_hz))
        try:
            m.get_constants(whose_poles="own")
        except np.linalg.LinAlgError:  # its LSFD fails (SVD did not converge): nothing found
            return np.zeros(0), np.zeros(0), np.zeros((0, 0))
    f, z, a = np.asarray(m.nat_freq), np.asarray(m.nat_xi), np.asarray(m.A)
    a = a.reshape(-1, f.size)
    keep = f > 0  # 0 Hz: no stable pole near the frequency asked
    return f[keep], z[keep], a[:, keep]


def compare(name: str, source: str, band: tuple[float, float], min_snr: float | None,
            hand: tuple[float, ...], order: int, repeat: int) -> str:
    """Fit one set with both and return its table row."""
    test = (GENERATED[source]() if source in GENERATED
            else read_test(REAL / source, require_driving=False))
    kw = {} if min_snr is None else {"min_snr": min_snr}
    t_b, t_s = [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fit = fit_test(test, band_hz=band, **kw)
        t_b.append(time.perf_counter() - t0)
    peaks = fit.peaks.freq_hz
    f_p = run_sdypy(test, peaks, order, band)[0]
    for _ in range(repeat):
        t0 = time.perf_counter()
        f_s, z_s, a_s = run_sdypy(test, fit.freq_hz, order, band)
        t_s.append(time.perf_counter() - t0)
    # modes both found: each batlab mode with its nearest sdypy mode within 1 %
    pairs = [(k, int(np.argmin(np.abs(f_s - f)))) for k, f in enumerate(fit.freq_hz)
             if f_s.size and np.min(np.abs(f_s / f - 1)) < 0.01]
    df = max((abs(f_s[j] / fit.freq_hz[k] - 1) for k, j in pairs), default=np.nan)
    dz = max((abs(z_s[j] / fit.damping_ratio[k] - 1) for k, j in pairs), default=np.nan)
    shapes_s = a_s
    if fit.shapes.shape[0] > 1 and pairs:
        macs = [float(mac(fit.shapes[:, [k]], shapes_s[:, [j]])[0, 0]) for k, j in pairs]
        mac_txt = f"{min(macs):.4f}"
    else:
        mac_txt = "-"
    ratio = np.median(t_s) / np.median(t_b) if fit.freq_hz.size else np.nan
    n_h = len(hand)
    return (f"| {name} | {n_h} | {hand_found(fit.freq_hz, hand)} of {n_h} | "
            f"{hand_found(f_p, hand)} of {n_h} | "
            f"{fit.freq_hz.size} | {f_p.size} | {len(pairs)} of {fit.freq_hz.size} | "
            f"{100 * df:.3f} | {100 * dz:.1f} | {mac_txt} | {np.median(t_b):.3f} | "
            f"{np.median(t_s):.3f} | {ratio:.2f} |")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--order", type=int, default=50, help="sdypy-EMA pol_order_high")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(f"real data, band 20 Hz to the last line; sdypy-EMA pol_order_high={args.order}, "
          "(a) given the sum-MIF peaks, (b) given batlab's frequencies")
    print("| data | hand analysis: modes | found by batlab (automatic) | found by sdypy-EMA "
          "(given the MIF peaks) | batlab modes (automatic) | "
          "sdypy-EMA modes, given the MIF peaks | "
          "sdypy-EMA given batlab's: found within 1 % | max freq diff % | "
          "max damping diff % | min MAC | batlab s | sdypy s | time sdypy/batlab |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, source, band, min_snr, hand in SETS:
        print(compare(name, source, band, min_snr, hand, args.order, args.repeat), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
