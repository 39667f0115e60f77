"""The inspection's shape-noise model (``run.differences``, ``SHAPE_NOISE_FLOOR_SHARE``).

An averaged FRF's random error is relative to |H| (var H / |H|^2 = (1 - gamma^2) /
(2 n gamma^2)), and near a resonance |H_j| ~ |phi_j|: a mode's identified shape is noisier
where it moves more (the thin handle, the barrel end) than near its nodes. Weighting every
point of a mode alike let the large-amplitude points dominate the residual, and a clean bat's
noise there read as a core. Check: on clean fleet bats measured with multiplicative FRF noise
(files, modal fits, calibration: the real path), the null fit's weighted shape residuals are
as large at a mode's nodes as at its antinodes.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from updating.inspect.fit import NullBounds, ParamSpace
from updating.inspect.model import ChangePredictor, baseline_sensor_offset
from updating.inspect.run import differences, fit_hypotheses, pair_tests

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import inspect_cache  # noqa: E402


def _null_residuals(bat: dict) -> tuple[np.ndarray, np.ndarray]:
    """(weighted null shape residual, |phi0| / rms(phi0)) per shape entry."""
    prof, ref, base, re = bat["profile"], bat["reference"], bat["baseline"], bat["retest"]
    points = np.asarray(base.x_m)
    predict = ChangePredictor(prof, ref, points, ref.sensor_x_m, re.freq_hz.size + 6)
    predict = predict.at_sensor(ref.sensor_x_m + baseline_sensor_offset(
        predict, base.freq_hz, base.shapes))
    pairs = pair_tests(predict, base, re, 0.8)
    dlnw = np.log(bat["conditions"].weight_kg / bat["registered"].weight_kg)
    diff = differences(predict, base, re, pairs, float(dlnw))
    space = ParamSpace(prof, NullBounds.physical(), 0.0, float(re.sensor_x_m - base.sensor_x_m))
    null = fit_hypotheses(predict, diff, space, 2).null
    m, n_psi = diff.n_freq, diff.dpsi.size
    r = null.residual[m:m + n_psi].reshape(diff.dpsi.shape)
    return r, np.abs(diff.phi0) / np.sqrt(np.mean(diff.phi0**2, axis=0))


def test_shape_residuals_are_as_large_at_nodes_as_at_antinodes():
    res, amp = zip(*(_null_residuals(inspect_cache.build_one(seed, "none", None))
                     for seed in (620, 7059, 8037)), strict=True)
    r, a = np.concatenate([x.ravel() for x in res]), np.concatenate([x.ravel() for x in amp])
    low, high = a <= np.quantile(a, 1 / 3), a >= np.quantile(a, 2 / 3)
    ratio = np.mean(r[high] ** 2) / np.mean(r[low] ** 2)
    # weighted alike at every point (the old model) the ratio is ~25
    assert 0.3 < ratio < 3.0, ratio
