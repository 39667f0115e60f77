"""The bat on the virtual rig, streamed over a serial port: every mode of its FE model in the
band is found at the default settings, the 2.09 kHz one (whose peak a null of the hammer's force
spectrum cuts, seen as a coherence dip) on its own peak."""

import json

import numpy as np
from test_serial_rig import ROOT, _batlab, _Rig

from batlab import pipeline
from updating.model.units import IN_TO_M

BAT = ROOT / "data_samples" / "smooth_bat"


def test_every_bat_mode_found_at_the_default_min_snr(tmp_path):
    meta = json.loads((BAT / "meta.json").read_text())
    n = len(meta["points_in"])
    rig = _Rig("--profile", str(BAT / "profile.csv"), "--meta", str(BAT / "meta.json"),
               "--seed", "2")
    try:
        out = tmp_path / "bat.uff"
        res = _batlab("acquire", "--port", rig.path, "--meta", str(BAT / "meta.json"),
                      "--points", ",".join(str(k) for k in range(1, n + 1)),
                      "--driving-point", str(n), "--hits", "2", "-o", str(out),
                      "--exp-window-tau", "0.5", "--json", timeout=120)
        assert res.returncode == 0, res.stderr
    finally:
        rig.close()
    fit = _batlab("fit", str(out), "--json", timeout=120)
    assert fit.returncode == 0, fit.stderr
    doc = json.loads(fit.stdout)
    found = np.array([m["frequency_hz"] for m in doc["modes"]])
    model, _ = pipeline.bat_modal_model(BAT / "profile.csv", BAT / "meta.json",
                                        np.array(meta["points_in"]) * IN_TO_M, None, None)
    true = model.freq_hz[(model.freq_hz > 20) & (model.freq_hz < 3150)]
    assert true.size == 6 and found.size == true.size, (found, true)
    assert np.max(np.abs(found / true - 1)) < 0.003, (found, true)
    kept = {round(d["frequency_hz"]): d for d in doc["decisions"] if d["kept"]}
    assert len(kept) == 6 and any(d["reason"] == "own_peak" for d in kept.values())
