"""Test-only stand-ins for the numerical stages, so the application layer (CLI, registry,
report) can be tested on its own. Each is small but honest about its inputs: the fitter picks
real peaks of the driving-point FRF, the inspector decides from the frequency shifts, so
a wrong file, a lost re-ordering or a swapped test changes what they return.

``use_standins(monkeypatch, ...)`` patches the stage calls: the modal fit where
``updating.correlate.fitted`` calls it, calibration and the inspection where
``batlab.pipeline.inspection`` calls them; pass ``fit=False`` etc. to keep a real stage.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from scipy.signal import find_peaks

from updating.inspect.details import InspectionDetails, ModePair
from updating.inspect.verdict import Verdict
from updating.model.reference import BatReference
from updating.model.units import IN_TO_M


def fake_fit(test, known_mass_kg=None):
    """Peaks of the driving-point |H| above 20 Hz; shapes from Im H at each peak (quadrature
    picking), at the impact points."""
    i, j = test.driving_point
    f = test.freq_hz
    mag = np.abs(test.frf[:, i, j])
    band = f >= 20.0
    peaks, _ = find_peaks(np.where(band, mag, 0.0), prominence=0.2 * np.median(mag[band]))
    peaks = peaks[np.argsort(mag[peaks])[::-1][:6]]
    peaks = np.sort(peaks)
    shapes = np.imag(test.frf[peaks, i, :]).T  # (n_ref, m)
    shapes = shapes / np.sqrt(np.abs(shapes[j]))[None, :] * np.sign(shapes[j])[None, :]
    return SimpleNamespace(
        freq_hz=f[peaks], damping_ratio=np.full(peaks.size, 0.005), real_shapes=shapes,
        x_m=test.x_m(test.reference_nodes), suspension_freq_hz=np.array([]),
        band_freq_hz=f, synth=test.frf * 1.02, sweep=None, stability=None)


def fake_calibrate(profile, meta, baseline_modes, suspension_hz=None):
    m = meta.material
    return SimpleNamespace(reference=BatReference(m.E_pa, m.rho_kg_m3, m.e_over_g,
                                                  sensor_x_m=baseline_modes.sensor_x_m),
                           extended=SimpleNamespace(rms_pct=0.0), warnings=())


def fake_inspect(profile, reference, baseline, retest, false_alarm, conditions=None,
                 registered=None, with_map=True, retest_profile=None, clean_F=None):
    """Altered when the modes shift unevenly (beyond a uniform drift); 1 in elements; the
    'core' sits in the last 10 in, its size from the largest uneven shift. A re-test profile
    is joined as the real inspection joins it (``caliper_verdict.with_calipers``: pure
    numpy, fast). A calibration's ``clean_F`` is not read: the stand-in decides on its own
    rule (its verdict says it decided on the nominal chance)."""
    from updating.inspect.caliper_verdict import with_calipers

    return with_calipers(_fake_modal(profile, baseline, retest, false_alarm), profile,
                         retest_profile, reference.rho_kg_m3)


def _fake_modal(profile, baseline, retest, false_alarm):
    n = min(baseline.freq_hz.size, retest.freq_hz.size)
    ratio = retest.freq_hz[:n] / baseline.freq_hz[:n]
    uneven = float(np.max(np.abs(ratio / np.median(ratio) - 1)))
    altered = uneven > 2e-3
    edges = np.linspace(0.0, profile.length_m, int(round(profile.length_m / IN_TO_M)) + 1)
    x0, x1 = edges[:-1], edges[1:]
    inside = (x0 >= profile.length_m - 10 * IN_TO_M) & (x1 <= profile.length_m - IN_TO_M)
    alpha = np.where(inside & altered, -0.1, 0.0) + 1e-4 * np.cos(x0)
    beta = np.where(inside & altered, -0.02, 0.0)
    region = (profile.length_m - 10 * IN_TO_M, profile.length_m - IN_TO_M)
    return Verdict(
        altered=altered, confidence=0.999 if altered else 0.3, false_alarm_rate=false_alarm,
        statistic=uneven, region_m=region, core_diameter_m=1.0 * IN_TO_M,
        fill_density_ratio=0.3, uncertainty={"core_diameter_m": 1e-3},
        element_x0_m=x0, element_x1_m=x1, alpha=alpha, beta=beta,
        moisture={"stiffness_scale": float(np.median(ratio) ** 2), "density_scale": 1.0},
        modes=tuple(ModePair(float(a), float(b))
                    for a, b in zip(baseline.freq_hz[:n], retest.freq_hz[:n], strict=True)),
        details=InspectionDetails(n))


def use_standins(monkeypatch, fit: bool = True, calibrate: bool = True,
                 inspect: bool = True) -> None:
    import batlab.pipeline.inspection as pipeline
    from updating.correlate import fitted

    if fit:
        monkeypatch.setattr(fitted, "fit_test", fake_fit)
    if calibrate:
        monkeypatch.setattr(pipeline, "calibrate", fake_calibrate)
    if inspect:
        monkeypatch.setattr(pipeline, "inspect", fake_inspect)


SAMPLE = Path("data_samples/smooth_bat")


def unchanged_retest(baseline: Path, out: Path, rel: float = 1e-3, seed: int = 0) -> Path:
    """A second test of the unaltered bat: the baseline's FRFs plus complex noise of ``rel``
    of their peak (a copy of the baseline is refused as a re-test: it is not a second test)."""
    from dataclasses import replace

    from ema.io.frf_io import read_test, write_test

    test = read_test(baseline)
    rng = np.random.default_rng(seed)
    scale = rel * float(np.max(np.abs(test.frf)))
    noise = scale * (rng.standard_normal(test.frf.shape) + 1j * rng.standard_normal(
        test.frf.shape)) / np.sqrt(2)
    write_test(out, replace(test, frf=test.frf + noise))
    return out


def stand_in_lab(tmp_path: Path, monkeypatch) -> Path:
    """A lab folder with the sample bat's files and a fresh registry ($BATLAB_DB), stand-in
    numerics."""
    use_standins(monkeypatch)
    for name in ("profile.csv", "meta.json", "baseline.uff", "retest_corked.uff"):
        shutil.copyfile(SAMPLE / name, tmp_path / name)
    monkeypatch.setenv("BATLAB_DB", str(tmp_path / "reg.sqlite"))
    return tmp_path


def run_cli(args, capsys) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of ``batlab`` with ``args``."""
    from batlab.cli import main

    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def bat_folders(tmp_path: Path, prefix: str, n: int) -> list[Path]:
    """``n`` lab folders, bats ``{prefix}-0`` ... ``{prefix}-{n-1}``: the sample's profile.csv
    and its meta.json with the serial changed (one registry, several bats)."""
    sample = SAMPLE.resolve()
    folders = []
    for k in range(n):
        folder = tmp_path / f"bat{k}"
        folder.mkdir()
        shutil.copyfile(sample / "profile.csv", folder / "profile.csv")
        meta = json.loads((sample / "meta.json").read_text())
        meta["serial"] = f"{prefix}-{k}"
        (folder / "meta.json").write_text(json.dumps(meta))
        folders.append(folder)
    return folders


def lab_worker(db: str, folder: str, n_inspections: int) -> None:
    """One lab in its own process: register the bat of ``folder`` on ``db`` and inspect the
    corked re-test ``n_inspections`` times (``--again``), the numerics stood in."""
    import batlab.pipeline.inspection as pipeline
    from batlab.cli import main
    from updating.correlate import fitted

    fitted.fit_test, pipeline.calibrate = fake_fit, fake_calibrate
    pipeline.inspect = fake_inspect
    d, sample = Path(folder), SAMPLE.resolve()
    serial = json.loads((d / "meta.json").read_text())["serial"]
    code = main(["register", "--profile", str(d / "profile.csv"), "--meta",
                 str(d / "meta.json"), "--baseline", str(sample / "baseline.uff"),
                 "--db", db, "--json"])
    assert code == 0
    for _ in range(n_inspections):
        assert main(["inspect", "--serial", serial, str(sample / "retest_corked.uff"),
                     "--db", db, "--json", "--again"]) == 0  # the same file: stored anew


def judged(out: dict) -> dict:
    """A verdict's JSON apart from where its chance was looked up.

    The registry form and the stateless form judge the same re-test the same way, but each
    says why its chance is unmeasured in its own words (no registry given, no calibration
    of the model stored): the chance's value is kept, its wording and source's reason not.
    """
    from batlab.formatting import chance_words

    said = chance_words(out.get("chance"))
    rest = {k: v for k, v in out.items() if k not in ("chance", "false_alarm_rate")}
    rest["reasons"] = [r.replace(said, "<chance>") if said else r for r in out["reasons"]]
    rest["chance_value"] = (out.get("chance") or {}).get("value")
    return rest


def main_with_standins(argv: list[str]) -> int:
    """``batlab argv`` with the stand-in numerics (a test's subprocess, ``python -c``, or a
    benchmark); the real stages are put back after."""
    import batlab.pipeline.inspection as pipeline
    from batlab.cli import main
    from updating.correlate import fitted

    real = fitted.fit_test, pipeline.calibrate, pipeline.inspect
    fitted.fit_test, pipeline.calibrate, pipeline.inspect = fake_fit, fake_calibrate, \
        fake_inspect
    try:
        return main(argv)
    finally:
        fitted.fit_test, pipeline.calibrate, pipeline.inspect = real
