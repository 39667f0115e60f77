"""The inspection's shape-noise model: per point (``changes.differences``,
``SHAPE_NOISE_FLOOR_SHARE``) and per mode (``fit.shape_noise``).

An averaged FRF's random error is relative to |H| (var H / |H|^2 = (1 - gamma^2) /
(2 n gamma^2)), and near a resonance |H_j| ~ |phi_j|: a mode's identified shape is noisier
where it moves more (the thin handle, the barrel end) than near its nodes. Weighting every
point of a mode alike let the large-amplitude points dominate the residual, and a clean bat's
noise there read as a core. Check: on clean fleet bats measured with multiplicative FRF noise
(files, modal fits, calibration: the real path), the null fit's weighted shape residuals are
as large at a mode's nodes as at its antinodes.

Modes are not measured equally well either (on clean fleet bats mode 1's residual variance
was ~4 times modes 2-4's under one common level): each mode's level is estimated from the
residuals, shrunk towards the common one. Checks: the level of a mode made noisier is
recovered, a clean bat with one noisy mode stays unaltered, and a cork core that one common
level hides (found on 4 of 10 such bats with it) is found and read.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from batlab.fleet import cache as inspect_cache
from updating.inspect.changes import differences, pair_tests
from updating.inspect.hypotheses import SHAPE_NOISE_PRIOR_POINTS, NullBounds, ParamSpace
from updating.inspect.model import ChangePredictor, baseline_sensor_offset
from updating.inspect.nested import fit_hypotheses
from updating.inspect.run import inspect_retest
from updating.model.sections import Core
from updating.model.units import IN_TO_M
from updating.simulate.fleet import random_case
from updating.simulate.virtual_bat import simulate_modes


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
    return null.shape_residual, np.abs(diff.phi0) / np.sqrt(np.mean(diff.phi0**2, axis=0))


def test_shape_residuals_are_as_large_at_nodes_as_at_antinodes():
    res, amp = zip(*(_null_residuals(inspect_cache.build_one(seed, "none", None))
                     for seed in (620, 7059, 8037)), strict=True)
    r, a = np.concatenate([x.ravel() for x in res]), np.concatenate([x.ravel() for x in amp])
    low, high = a <= np.quantile(a, 1 / 3), a >= np.quantile(a, 2 / 3)
    ratio = np.mean(r[high] ** 2) / np.mean(r[low] ** 2)
    # weighted alike at every point (the old model) the ratio is ~25
    assert 0.3 < ratio < 3.0, ratio


def _noisy_mode_tests(seed: int, core_d_in: float | None, noisy: int, factor: float = 5.0):
    """A random bat's two tests (simulated modes, 1.5 % shape noise, mode ``noisy``
    ``factor`` times noisier), with a cork core (ratio 0.3, 7 in behind a 1 in plug) of
    ``core_d_in`` in the re-test, or none."""
    rng = np.random.default_rng(seed)
    case = random_case(rng, "none")
    if core_d_in is not None:
        core = Core(core_d_in * IN_TO_M, 8 * IN_TO_M, 0.3, 0.0, IN_TO_M)
        case = replace(case, retest=replace(case.retest, core=core))
    level = np.full(6, 0.015)
    level[noisy] *= factor
    base, re = (simulate_modes(bat, 6, 3e-4, level, seed=int(rng.integers(2**31)))
                for bat in (case.baseline, case.retest))
    return case, base, re


@settings(max_examples=4, deadline=None, derandomize=True)
@given(seed=st.integers(0, 10**6), noisy=st.integers(0, 5))
def test_a_noisier_mode_is_weighted_down_and_a_clean_bat_stays_unaltered(seed, noisy):
    """One mode five times noisier than the others: its estimated level is 5 times theirs,
    less the shrinkage towards the common level (within 35 %), and the verdict is "not
    altered"."""
    case, base, re = _noisy_mode_tests(seed, None, noisy)
    v = inspect_retest(case.profile, case.reference, base, re, false_alarm=0.01)
    assert v.altered is False, v.reasons
    s = np.asarray(v.details.fit.shape_noise_rel)
    ratio = s[noisy] / np.median(np.delete(s, noisy))
    n, n0, m = base.x_m.size, SHAPE_NOISE_PRIOR_POINTS, s.size
    pooled = (25.0 + m - 1) / m
    expected = np.sqrt((n * 25.0 + n0 * pooled) / (n * 1.0 + n0 * pooled))
    assert ratio == pytest.approx(expected, rel=0.35), (ratio, expected)


@settings(max_examples=3, deadline=None, derandomize=True)
@given(seed=st.integers(0, 10**6), d_in=st.floats(0.75, 0.85))
def test_a_cork_core_is_found_beside_a_noisy_first_mode(seed, d_in):
    """Mode 1 five times noisier than modes 2-6 (as on the fleet's clean bats) and a cork core
    0.75-0.85 in x 7 in: altered, its start within 1.5 in, its diameter within 15 %. Weighted
    with one common level, 6 of 10 such bats read "not altered" (F 5.6-9.8)."""
    case, base, re = _noisy_mode_tests(seed, d_in, 0)
    v = inspect_retest(case.profile, case.reference, base, re, false_alarm=0.01)
    assert v.altered is True, v.reasons
    L = case.profile.length_m
    assert v.region_m[0] == pytest.approx(L - 8 * IN_TO_M, abs=1.5 * IN_TO_M)
    assert v.core_diameter_m == pytest.approx(d_in * IN_TO_M, rel=0.15)
