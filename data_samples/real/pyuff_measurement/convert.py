"""Rewrite the source export in batlab's UFF layout (run from the repository root).

    python data_samples/real/pyuff_measurement/convert.py

Reads ``meas_point_1.txt`` .. ``meas_point_3.txt`` (the source's accelerance FRFs, one
complex number per line, 0-1000 Hz at 1 Hz; the source's own README writes them to UFF with
response node 1 and reference nodes 1, 2, 3, direction 1, no node geometry) and writes,
keeping every FRF value as it is:

- ``test.uff``: all three FRFs (response node 1, impacts at nodes 1, 2, 3; driving point 1-1);
- ``one_frf.uff``: the driving-point FRF alone (a single-FRF analyser export);
- ``two_nodes.uff``: the FRFs of impacts 1 and 2 (a two-node test);
- ``no_driving_point.uff``: the FRFs of impacts 2 and 3 (no driving point: unscaled shapes).

The 0 Hz line (the source replaces it by NaN before writing its UFF) is kept as read: the fit
never uses 0 Hz. The source has no geometry: nodes are placed 0.1 m apart
(x = 0.1 (node - 1)), and direction 1 is relabelled as batlab's transverse axis (3). Units:
the source calls them accelerance, taken as (m/s^2)/N.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ema.io.frf_data import FrfTest
from ema.io.uff import write_uff

HERE = Path(__file__).resolve().parent


def main() -> None:
    h = np.stack([np.loadtxt(HERE / f"meas_point_{k}.txt", dtype=complex) for k in (1, 2, 3)],
                 axis=1)[:, None, :]
    freq = np.arange(h.shape[0], dtype=float)  # 0..1000 Hz at 1 Hz
    refs = np.array([1, 2, 3])
    x = {int(n): 0.1 * (int(n) - 1) for n in refs}
    for name, cols in (("test", [0, 1, 2]), ("one_frf", [0]), ("two_nodes", [0, 1]),
                       ("no_driving_point", [1, 2])):
        test = FrfTest(freq, h[:, :, cols], np.array([1]), refs[cols], x,
                       meta={"source": "ladisk/pyuff data/meas_point_1..3.txt"})
        write_uff(HERE / f"{name}.uff", test)


if __name__ == "__main__":
    main()
