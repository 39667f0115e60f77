"""The decision's reasons say what to do with what the lab already gave (issue 50, item 3):
a bat whose re-test weight came with retest.json is not asked to be weighed or to give it,
a bat without it is; the reasons carry no statistic's name, and read as sentences."""

from __future__ import annotations

import pytest

from updating.inspect.decision import Evidence, decide
from updating.inspect.finding import describe, found
from updating.inspect.kind_table import kind
from updating.model.units import IN_TO_M


def _core_evidence(**kw) -> Evidence:
    f = found(kind("filled"), (28.0 * IN_TO_M, 32.0 * IN_TO_M),
              {"core_diameter_m": 0.5 * IN_TO_M, "fill_density_ratio": 0.4},
              {"core_diameter_m": 0.05 * IN_TO_M, "fill_density_ratio": 0.1}, "core")
    base = dict(F=20.0, p_value=1e-6, significant=True, large=True, F_fit=40.0, finding=f,
                finding_text=describe(f), held_null=(), held_core=("barrel_end_moisture_pt",),
                dlnw=None)
    return Evidence(**{**base, **kw})


@pytest.mark.parametrize("case", ["drift", "large", "gate"])
@pytest.mark.parametrize("dlnw", [None, -0.012])
def test_the_scale_and_retest_json_are_asked_for_only_when_missing(case, dlnw):
    e = {"drift": _core_evidence(dlnw=dlnw, F_wide=None),
         "large": _core_evidence(dlnw=dlnw, significant=False, p_value=0.02, held_core=()),
         "gate": _core_evidence(dlnw=dlnw, finding_text="a change", F_fit=5.0, large=False,
                                held_core=(), finding=None)}[case]
    altered, reasons = decide(e)
    assert altered is None, reasons
    text = " ".join(reasons).lower()
    assert ("weigh the bat" in text) == (dlnw is None), text
    assert ("give retest.json" in text) == (dlnw is None and case != "gate"), text
    assert " f " not in text and "(f " not in text, text
    assert ", and " not in text and "  " not in text, text
