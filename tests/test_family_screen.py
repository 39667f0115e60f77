"""The kinds' families are fitted only when the generic change may matter
(``nested.families_needed``, issue 51).

A family (core, added mass, diameter loss) only lowers H1's residual below the generic local
change's; when the test with the generic change as H1 is far from significant and from large,
the decision never reads the families, and skipping them is half a clean bat's inspection.
Checks: the screen's thresholds; on clean re-tests of the built-in bat the screened
inspection gives the status the families' fits give, and nearly their F; a hidden cork core
still gets its families and is found.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from batlab.fleet.calibrate import BatSpec, inspect_clean
from updating.inspect import nested
from updating.inspect.decision import CLEAR_LEVEL, F_FLOOR
from updating.inspect.nested import SCREEN_F_FIT, SCREEN_LEVEL, NestedTest, families_needed
from updating.inspect.run import inspect_retest
from updating.model.sections import Core
from updating.model.units import IN_TO_M
from updating.simulate.fleet import random_case
from updating.simulate.virtual_bat import simulate_modes


def _test(p: float, F_fit: float) -> NestedTest:
    return NestedTest(F=1.0, p_value=p, q=4, dof=40, n=48, rss_null=50.0, rss_core=40.0,
                      F_fit=F_fit, p_fit=0.5)


def test_the_screen_sits_well_inside_the_decisions_thresholds():
    assert SCREEN_LEVEL >= 10 * CLEAR_LEVEL and SCREEN_F_FIT <= F_FLOOR / 2
    assert not families_needed(_test(SCREEN_LEVEL, 0.0))
    assert not families_needed(_test(0.9, np.nextafter(SCREEN_F_FIT, 0)))
    assert families_needed(_test(np.nextafter(SCREEN_LEVEL, 0), 0.0))
    assert families_needed(_test(0.9, SCREEN_F_FIT))
    assert families_needed(_test(CLEAR_LEVEL / 2, F_FLOOR))


def _watched(monkeypatch) -> list[bool]:
    said: list[bool] = []
    screen = nested.families_needed

    def watch(test):
        said.append(screen(test))
        return said[-1]

    monkeypatch.setattr(nested, "families_needed", watch)
    return said


SPEC = BatSpec("batlab/builtin/profile.csv", "batlab/builtin/meta.json", 2026)


@pytest.mark.parametrize("i", [1, 3])
def test_a_screened_clean_bat_reads_as_with_every_family(monkeypatch, i):
    said = _watched(monkeypatch)
    screened = inspect_clean(SPEC, i)
    assert said == [False]  # the families were skipped
    monkeypatch.setattr(nested, "SCREEN_LEVEL", 1.1)  # every change "may matter"
    full = inspect_clean(SPEC, i)
    assert said == [False, True]
    assert screened["status"] == full["status"] == "not_altered"
    # F moves only where a family fitted better than the generic change and set H1's noise
    # (the validation fleet's clean bats: by less than 0.4, at F below 2)
    assert abs(screened["F"] - full["F"]) < 0.5


def test_a_hidden_cork_core_gets_its_families(monkeypatch):
    said = _watched(monkeypatch)
    rng = np.random.default_rng(5101)
    case = random_case(rng, "none")
    core = Core(1.0 * IN_TO_M, 8 * IN_TO_M, 0.3, 0.0, IN_TO_M)
    case = replace(case, retest=replace(case.retest, core=core))
    level = np.full(6, 0.01)
    base, re = (simulate_modes(bat, 6, 3e-4, level, seed=int(rng.integers(2**31)))
                for bat in (case.baseline, case.retest))
    v = inspect_retest(case.profile, case.reference, base, re, with_map=False)
    assert said[0] is True
    assert v.altered is True and v.finding is not None and v.finding.kind == "core"
