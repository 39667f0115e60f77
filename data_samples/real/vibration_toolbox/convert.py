"""Rewrite the source's analyser exports in batlab's UFF layout (run from the repository root).

    python data_samples/real/vibration_toolbox/convert.py

Reads ``case1.mat`` and ``case2.mat`` (kept unchanged: the example data of the
``vibrationtoolbox/vibration_toolbox`` package, ``vibration_toolbox/data/``), each one
two-channel measurement exported by the analyser: the FRF ``Hf_chan_2`` (channel 2 over
channel 1) and its coherence ``Hf_coh_chan_2`` on ``Freq_domain`` (0-500 Hz at 0.3125 Hz,
1601 lines), and writes ``case1.uff`` and ``case2.uff`` keeping every FRF and coherence value
as it is.

The source records neither the object nor where the force and the sensor were: the response
is numbered node 2 and the force node 1 (0.1 m apart), so the test has no driving point and
its shapes are unscaled; the source does not give units either: the FRF is written as
accelerance, only frequencies and damping are meaningful.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.io import loadmat

from ema.io.frf_data import FrfTest
from ema.io.uff import write_uff

HERE = Path(__file__).resolve().parent


def main() -> None:
    for name in ("case1", "case2"):
        mat = loadmat(HERE / f"{name}.mat")
        freq_hz = mat["Freq_domain"].ravel().astype(float)
        h = mat["Hf_chan_2"].ravel().astype(complex)[:, None, None]
        coh = mat["Hf_coh_chan_2"].ravel().astype(float)[:, None, None]
        test = FrfTest(freq_hz, h, np.array([2]), np.array([1]), {1: 0.0, 2: 0.1},
                       coherence=np.clip(coh, 0.0, 1.0),
                       meta={"source": f"vibrationtoolbox/vibration_toolbox data/{name}.mat"})
        write_uff(HERE / f"{name}.uff", test)


if __name__ == "__main__":
    main()
