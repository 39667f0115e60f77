"""The decision on the measured chance (issue 47, part 3): where a calibration of the bat's
model holds enough clean re-tests, "beyond drift" reads the chance measured among their F;
with too few, or none, the F distribution's. The cut past which the measured chance is below
a level agrees with the chance itself; the calibration's false-alarm count is stated only
where it bounds the measured decision; the words say which chance decided."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from batlab.formatting import chance_words, false_alarm_words
from batlab.pipeline.chance import rows_bound_decision
from updating.inspect.decision import CLEAR_LEVEL, decided_chance
from updating.tails import f_isf, f_sf, measured_chance, measured_cut

NULLS = st.lists(st.one_of(st.none(), st.floats(0.0, 30.0, allow_nan=False)), min_size=1,
                 max_size=4000)


@settings(max_examples=150, deadline=None)
@given(NULLS, st.floats(1e-4, 0.2), st.floats(0.0, 40.0, allow_nan=False))
def test_the_cut_is_where_the_measured_chance_falls_below_the_level(null, level, F):
    values = np.array([math.nan if v is None else v for v in null])
    cut = measured_cut(values, level)
    assert (measured_chance(F, values).value < level) == (F > cut)
    if 1.0 / (values.size + 1) >= level:
        assert cut == math.inf


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 3000), st.integers(0, 12), st.floats(0.5, 20.0))
def test_the_decision_reads_the_measured_chance_only_where_it_can_reach_the_level(n, b, F):
    """Hide b clean re-tests at or above F among n: the decided chance is (1 + b) / (n + 1)
    when n re-tests can show a chance below 0.1 %, else the nominal p, untouched."""
    b = min(b, n)
    null = np.concatenate([np.full(b, F + 1.0), np.full(n - b, F / 2)])
    p_nominal = f_sf(F, 4, 90)
    chance, source = decided_chance(F, p_nominal, null, 0.01)
    if 1.0 / (n + 1) < CLEAR_LEVEL:
        assert (chance, source) == ((1 + b) / (n + 1), "calibration")
    else:
        assert (chance, source) == (p_nominal, "nominal")
    assert decided_chance(F, p_nominal, None, 0.01) == (p_nominal, "nominal")


def test_f_isf_inverts_the_survival_function():
    for q, dof in ((4, 95), (4, 60), (5, 200)):
        for p in (1e-2, 1e-3, 1e-5):
            assert f_sf(f_isf(p, q, dof), q, dof) == pytest.approx(p, rel=1e-8)


def test_the_rows_bound_the_measured_decision_only_where_it_is_the_stricter():
    """The nominal decision's alarms include the measured one's exactly when the measured
    cut is at or past the F distribution's critical value at the inspection's dof."""
    crit = f_isf(CLEAR_LEVEL, 4, 95)  # 5.04
    heavy = np.r_[np.full(3, crit + 1.0), np.linspace(0.0, 1.0, 2997)]  # cut at crit + 1
    light = np.r_[np.full(3, crit - 1.0), np.linspace(0.0, 1.0, 2997)]  # cut below crit
    assert rows_bound_decision(heavy, 0.01, (4, 95))
    assert not rows_bound_decision(light, 0.01, (4, 95))
    assert not rows_bound_decision(heavy, 0.01, None)


def test_the_words_say_which_chance_decided():
    cal = {"model": "M", "n": 64, "exceeding": 3}
    nominal_decided = {"value": 4 / 65, "source": "calibration", "calibration": cal,
                       "nominal": 2e-4, "decided_on": "nominal"}
    said = chance_words(nominal_decided)
    assert "as measured on 64 clean re-tests" in said
    assert "decided on the F distribution's nominal below 0.1 %" in said
    measured = dict(nominal_decided, calibration=dict(cal, n=3000), decided_on="calibration")
    assert "decided on" not in chance_words(measured)
    fa = {"source": "calibration", "false_alarms": 0, "n": 3000, "upper95": 0.001,
          "level": 0.01, "model": "M"}
    assert "as measured on the calibration" in false_alarm_words(dict(fa,
                                                                       decided_on="calibration"))
    assert "the F test's nominal 1 %" in false_alarm_words(dict(fa, decided_on="nominal"))


_CORKED: dict = {}


def _corked():
    """A random bat with a cork core, its tests' modes and its nominal verdict (once)."""
    if not _CORKED:
        from updating.inspect.run import inspect_retest
        from updating.simulate.fleet import case_modes, random_case

        rng = np.random.default_rng(12)
        case = random_case(rng, "cork")
        base, re = case_modes(case, rng)
        _CORKED.update(case=case, modes=(base, re), nominal=inspect_retest(
            case.profile, case.reference, base, re, false_alarm=0.01, with_map=False))
    return _CORKED


@settings(max_examples=1, deadline=None, derandomize=True)
@given(n=st.integers(1000, 3000), b=st.integers(0, 5))
@example(n=3000, b=1)  # 2 / 3001: below 0.1 %
@example(n=1500, b=3)  # 4 / 1501: not
def test_a_hidden_calibration_decides_a_cored_bat(n, b):
    """Hide a calibration of n clean re-tests, b of them at or above the cored bat's F, and
    inspect it through the real method: altered exactly when (1 + b) / (n + 1) is below
    0.1 % (the nominal chance is far below it either way), never acquitted, and the verdict
    says it decided on the calibration."""
    from updating.inspect.run import inspect_retest

    got = _corked()
    nominal = got["nominal"]
    assert nominal.altered is True and nominal.details.fit.decided_on == "nominal"
    F = nominal.statistic
    null = np.concatenate([np.full(b, 2 * F), np.linspace(0.0, F / 2, n - b)])
    case, (base, re) = got["case"], got["modes"]
    v = inspect_retest(case.profile, case.reference, base, re, false_alarm=0.01,
                       with_map=False, clean_F=null)
    assert v.statistic == nominal.statistic  # the calibration moves the decision, not F
    assert v.details.fit.decided_on == "calibration"
    significant = (1 + b) / (n + 1) < CLEAR_LEVEL
    assert (v.altered is True) == significant, v.reasons
    if not significant:
        assert v.altered is None, v.reasons  # large and read as a core: never acquitted
