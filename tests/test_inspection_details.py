"""The inspection's typed evidence read back from its stored form: ``from_json_dict`` is the
inverse of ``to_json_dict`` on any evidence (hypothesis), through JSON as the registry stores
it, and an older record missing keys reads as "not computed" instead of failing.
(Real stored records: tests/test_cli_inspect_real.py.)"""

from __future__ import annotations

import json
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from batlab.formatting import p_value
from batlab.pipeline import jsonable
from updating.inspect.details import (
    CoreCandidate,
    ElementMap,
    FitEvidence,
    InspectionDetails,
    ModePair,
)
from updating.inspect.msso_map import MssoMap

num = st.floats(-1e6, 1e6, allow_nan=False)
maybe_num = st.none() | num
nan_or_num = st.just(math.nan) | num  # NaN is stored as null and read back as NaN
names = st.text("abcdefgh_", min_size=1, max_size=8)


def stored(obj: dict) -> dict:
    """As the registry keeps it: JSON types (NaN -> null), through a JSON text."""
    return json.loads(json.dumps(jsonable(obj)))


@st.composite
def element_maps(draw):
    kind = draw(st.sampled_from(["none", "error", "map"]))
    if kind == "none":
        return ElementMap()
    if kind == "error":
        return ElementMap(error=draw(st.text(max_size=20)))
    e = draw(st.integers(1, 6))
    arr = st.lists(num, min_size=e, max_size=e).map(np.array)
    x0 = np.arange(e, dtype=float)
    region = draw(st.none() | st.tuples(num, num))
    result = MssoMap(x0, x0 + 1, draw(arr), draw(arr), draw(arr), draw(arr), region,
                     draw(nan_or_num), draw(st.integers(0, 50)), draw(nan_or_num),
                     draw(st.integers(0, 500)), draw(nan_or_num),
                     tuple(draw(st.lists(names, max_size=3))), draw(num))
    return ElementMap(result, draw(st.none() | st.booleans()))


@st.composite
def details(draw):
    n_modes = draw(st.integers(0, 12))
    time_s = draw(st.none() | num)
    if draw(st.booleans()):
        return InspectionDetails(n_modes, time_s)
    floats = st.lists(num, max_size=5).map(tuple)
    core = CoreCandidate((draw(nan_or_num), draw(nan_or_num)), draw(nan_or_num),
                         draw(nan_or_num), draw(st.dictionaries(names, num, max_size=3)))
    fit = FitEvidence(
        draw(names), (draw(st.integers(0, 9)), draw(st.integers(0, 999))), draw(nan_or_num),
        draw(nan_or_num), draw(nan_or_num), draw(st.integers(0, 999)), draw(floats),
        draw(floats), draw(st.dictionaries(names, num, max_size=4)),
        tuple(draw(st.lists(names, max_size=3))), tuple(draw(st.lists(names, max_size=3))),
        draw(maybe_num), draw(names), draw(floats), core,
        draw(st.dictionaries(names, num, max_size=3)), draw(nan_or_num), draw(nan_or_num),
        draw(element_maps()), draw(nan_or_num), draw(nan_or_num))
    return InspectionDetails(n_modes, draw(maybe_num), fit)


@settings(max_examples=150, deadline=None)
@given(details())
def test_details_round_trip_through_the_stored_form(d):
    record = stored(d.to_json_dict())
    back = InspectionDetails.from_json_dict(record)
    assert stored(back.to_json_dict()) == record
    assert (back.fit is None) == (d.fit is None)
    if d.fit is not None:
        assert back.fit.statistic == d.fit.statistic and back.fit.dof == d.fit.dof
        assert (back.msso.result is None) == (d.fit.msso.result is None)
        assert back.msso.error == d.fit.msso.error


def test_a_record_with_one_shape_noise_level_reads_as_one_level():
    """Records stored before the shape noise was per mode hold one number."""
    record = stored(InspectionDetails(2, 1.0, None).to_json_dict())
    record.update(statistic="F", p_value=0.5, shape_noise_rel=0.01)
    assert InspectionDetails.from_json_dict(record).fit.shape_noise_rel == (0.01,)


@settings(max_examples=100, deadline=None)
@given(st.builds(ModePair, num, num, *[st.none() | nan_or_num] * 6))
def test_mode_pair_round_trip(m):
    record = stored(m.to_json_dict())
    back = ModePair.from_json_dict(record)
    assert stored(back.to_json_dict()) == record
    for k, v in vars(m).items():  # None stays None, NaN stays NaN, numbers stay
        w = getattr(back, k)
        assert (v is None and w is None) or (math.isnan(v) and math.isnan(w)) or v == w


def test_element_ends_given_to_the_map():
    m = MssoMap(np.zeros(2), np.ones(2), np.array([0.1, -0.2]), np.zeros(2), np.ones(2),
                np.ones(2), (0.5, 0.9), 3.0, 4, 1.0, 10, 2.0, ("bend",), 0.1)
    record = stored(ElementMap(m, True).to_json_dict())
    back = ElementMap.from_json_dict(record, [0.0, 0.4], [0.4, 0.9])
    assert np.array_equal(back.result.x0_m, [0.0, 0.4])
    assert back.region_m == (0.5, 0.9) and back.agrees_with_fit is True
    assert np.isnan(ElementMap.from_json_dict(record).result.x0_m).all()


def test_older_records_missing_keys_read_as_not_computed():
    assert InspectionDetails.from_json_dict(None) == InspectionDetails(0)
    assert InspectionDetails.from_json_dict({}).p_value is None
    old = InspectionDetails.from_json_dict({"p_value": 0.2, "n_modes": 5})
    assert old.p_value == 0.2 and old.n_modes == 5 and old.time_s is None
    assert old.msso.result is None and old.msso.error is None
    assert old.fit.weight_change_rel is None
    # a key no longer written (the empty position scan every record held) is ignored
    scan = {"p_value": 0.2, "position_scan": {}}
    assert "position_scan" not in InspectionDetails.from_json_dict(scan).to_json_dict()
    assert math.isnan(old.fit.candidate_core.diameter_m)
    assert ElementMap.from_json_dict({"alpha": [0.1]}).result.alpha_std.size == 0
    assert math.isnan(ModePair.from_json_dict({"retest_hz": 5.0}).baseline_hz)
    # the terminal's p-value reads the same through the typed details
    assert p_value({"details": {"p_value": 0.25}, "confidence": 0.1}) == 0.25
    assert math.isclose(p_value({"details": {}, "confidence": 0.9}), 0.1)
    assert p_value({"details": None}) is None
    assert p_value({"details": {"p_value": None, "statistic": "F"}, "confidence": 0.75}) == 0.25
