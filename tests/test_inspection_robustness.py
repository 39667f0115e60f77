"""An alteration must not rest on one mode (``updating.inspect.robustness``).

Hidden: a large cork core whose effect reaches the re-test through one mode only (every
other mode of the re-test is the unaltered bat's, moisture and noise included).

- The leave-one-out check, given a large core whose every mode but one is measured a hundred
  times worse (so one mode alone carries it), names that mode as the one the finding rests
  on, and the decision calls it inconclusive, naming the mode.
- Through the whole inspection (the noise estimated under H0) such a change is never called
  altered, and the verdict does not rest on it.
- The same core seen by every mode is altered, survives every leave-out, and its spread is
  recorded.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from updating.inspect import robustness
from updating.inspect.changes import differences, identify_pairs, pair_tests
from updating.inspect.decision import Evidence, decide, kind_supported
from updating.inspect.hypotheses import (
    NullBounds,
    ParamSpace,
    covariance,
    fit_core,
    fit_null,
    residual_function,
)
from updating.inspect.kinds import N_PARAMS, read_finding
from updating.inspect.robustness import leave_one_out, left_out_rows
from updating.inspect.run import _predictor, inspect_retest
from updating.model.sections import Core
from updating.model.units import IN_TO_M
from updating.simulate.fleet import random_case
from updating.simulate.virtual_bat import simulate_modes


def _modes(case, seed: int):
    """Baseline, clean re-test and cored re-test modes, the same noise draws in both."""
    cored = replace(case.retest, core=Core(1.2 * IN_TO_M, 11.0 * IN_TO_M, 0.25, 0.0, IN_TO_M))
    base = simulate_modes(case.baseline, 6, 3e-4, 0.015, seed=seed)
    clean = simulate_modes(case.retest, 6, 3e-4, 0.015, seed=seed + 1)
    core = simulate_modes(cored, 6, 3e-4, 0.015, seed=seed + 1)
    return base, clean, core


def _one_mode(clean, cored, k: int, amp: float = 3.0):
    """The clean re-test with mode k's change made ``amp`` times the core's."""
    one = replace(clean, freq_hz=clean.freq_hz.copy(), shapes=clean.shapes.copy())
    one.freq_hz[k] = clean.freq_hz[k] * (cored.freq_hz[k] / clean.freq_hz[k]) ** amp
    one.shapes[:, k] = clean.shapes[:, k] + amp * (cored.shapes[:, k] - clean.shapes[:, k])
    return one


@pytest.mark.parametrize("seed", [21, 22, 25])
def test_the_leave_one_out_check_names_the_one_mode_a_core_rests_on(seed):
    case = random_case(np.random.default_rng(seed), "none")
    base, clean, cored = _modes(case, seed)
    k = int(np.argmax(np.abs(np.log(cored.freq_hz / clean.freq_hz))))
    predict, _ = _predictor(case.profile, case.reference, base, cored)
    pairs, _ = identify_pairs(predict, base, cored, pair_tests(predict, base, cored, 0.8))
    diff = differences(predict, base, cored, pairs, None)
    kk = int(np.flatnonzero(pairs.baseline_index == k)[0])
    # every mode but k measured 100 times worse: only mode k can carry the core
    blur = np.where(np.arange(diff.n_freq) == kk, 1.0, 100.0)
    diff = replace(diff, sigma_lnf=diff.sigma_lnf * blur)
    space = ParamSpace(case.profile, NullBounds.physical())
    sigma = 0.02 * blur
    null = fit_null(predict, diff, space, sigma)
    fit = fit_core(predict, diff, space, sigma, null)
    cov = covariance(fit, diff.n_data - N_PARAMS["core"] - 10)
    finding = read_finding("core", fit, space, cov, predict)
    assert kind_supported(finding) and null.rss > 20 * fit.rss  # found, on all the data
    labels = [f"mode {j + 1}" for j in range(diff.n_freq)]
    rob = leave_one_out(predict, diff, space, sigma, null, fit, "core", finding, 0.01, labels,
                        base.x_m)
    assert len(rob.cases) == diff.n_freq + base.x_m.size
    assert [c.index for c in rob.failing] == [kk]
    assert rob.failing[0].what == "mode"
    evidence = Evidence(F=20.0, p_value=1e-6, significant=True, large=True,
                        finding=finding, finding_text="a core", held_null=(), held_core=(),
                        dlnw=None, rests_on=tuple(c.label for c in rob.failing))
    altered, reasons = decide(evidence)
    assert altered is None and f"mode {kk + 1}" in reasons[0] and "alone" in reasons[0]


@pytest.mark.parametrize("seed", [21, 22])
def test_a_core_seen_through_one_mode_alone_is_never_called_altered(seed):
    case = random_case(np.random.default_rng(seed), "none")
    base, clean, cored = _modes(case, seed)
    k = int(np.argmax(np.abs(np.log(cored.freq_hz / clean.freq_hz))))
    v = inspect_retest(case.profile, case.reference, base, _one_mode(clean, cored, k))
    assert v.altered is not True, v.reasons


def test_a_core_seen_by_every_mode_survives_every_leave_out():
    case = random_case(np.random.default_rng(23), "none")
    base, _, cored = _modes(case, 23)
    L = case.profile.length_m
    v = inspect_retest(case.profile, case.reference, base, cored, false_alarm=0.01)
    assert v.altered is True, v.reasons
    loo = v.details.fit.leave_one_out
    assert len(loo["cases"]) == v.details.n_modes + base.x_m.size
    assert all(c["survives"] for c in loo["cases"])
    lo, hi = loo["spread"]["core_diameter_m"]
    assert lo <= v.core_diameter_m <= hi + 1e-9
    assert hi - lo < 0.3 * v.core_diameter_m
    assert v.region_m[0] == pytest.approx(L - 11.0 * IN_TO_M, abs=1.5 * IN_TO_M)


@pytest.mark.parametrize("what", ["mode", "point"])
def test_the_rows_left_out_are_the_reduced_changes_residual(what):
    """``left_out_rows`` names exactly the rows ``Differences.without_mode``/``_point`` drop:
    the reduced residual at any x is the full one without them."""
    case = random_case(np.random.default_rng(24), "none")
    base, _, cored = _modes(case, 24)
    predict, _ = _predictor(case.profile, case.reference, base, cored)
    pairs, _ = identify_pairs(predict, base, cored, pair_tests(predict, base, cored, 0.8))
    diff = differences(predict, base, cored, pairs, 0.01)
    space = ParamSpace(case.profile, NullBounds.physical())
    sigma = np.linspace(0.01, 0.03, diff.n_freq)
    x = np.clip(np.random.default_rng(1).normal(0, 0.3, len(space.bounds.lower)),
                space.bounds.lower, space.bounds.upper)
    full = residual_function(predict, diff, space, sigma)(x)
    for k in range(diff.n_freq if what == "mode" else diff.dpsi.shape[0]):
        d, s = (diff.without_mode(k), np.delete(sigma, k)) if what == "mode" else \
            (diff.without_point(k), sigma)
        keep = np.ones(full.size, bool)
        keep[left_out_rows(diff, what, k)] = False
        np.testing.assert_array_equal(residual_function(predict, d, space, s)(x), full[keep])


def test_predicted_leave_outs_read_as_their_refits(monkeypatch):
    """The first-order leave-outs (``linearised``) of a core every mode sees are taken only
    where they survive by far, and read as the refits do: the same survival, F within 10 %,
    the diameter within 0.02 in; with ``LINEAR_MARGIN`` 0 every leave-out is refitted."""
    case = random_case(np.random.default_rng(23), "none")
    base, _, cored = _modes(case, 23)
    v = inspect_retest(case.profile, case.reference, base, cored, with_map=False)
    monkeypatch.setattr(robustness, "LINEAR_MARGIN", 0.0)
    w = inspect_retest(case.profile, case.reference, base, cored, with_map=False)
    assert v.altered is w.altered is True
    fast, slow = v.details.fit.leave_one_out["cases"], w.details.fit.leave_one_out["cases"]
    assert all(c["refitted"] for c in slow)
    assert sum(not c["refitted"] for c in fast) >= len(fast) // 2
    for a, b in zip(fast, slow, strict=True):
        assert a["survives"] == b["survives"]
        assert a["F"] == pytest.approx(b["F"], rel=0.1)
        d = a["reading"]["core_diameter_m"] - b["reading"]["core_diameter_m"]
        assert abs(d) < 0.02 * IN_TO_M
