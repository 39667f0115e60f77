"""The detection study's 90 % volume: a logistic in log volume, hidden and found again."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.simulate.detection import volume_found
from updating.simulate.limits import core_volume_in3


@settings(max_examples=15, deadline=None)
@given(v90=st.floats(0.3, 4.0), slope=st.floats(2.0, 6.0), seed=st.integers(0, 2**16))
def test_a_hidden_logistic_is_found_again(v90, slope, seed):
    """P(found) = 1 / (1 + exp(-slope ln(V / V50))), V90 = V50 9^(1/slope); 3,000 cores
    log-uniform over 0.1-12 in^3: V90 recovered within 15 %."""
    rng = np.random.default_rng(seed)
    v = np.exp(rng.uniform(np.log(0.1), np.log(12.0), 3000))
    v50 = v90 / 9.0 ** (1.0 / slope)
    found = rng.random(v.size) < 1.0 / (1.0 + np.exp(-slope * np.log(v / v50)))
    assert volume_found(v, found) == pytest.approx(v90, rel=0.15)


def test_separated_fleets_fall_between_and_degenerate_ones_give_none():
    v = np.array([0.3, 0.6, 1.2, 2.4, 4.8] * 4)
    assert 0.6 < volume_found(v, v > 1.0) < 1.2
    assert volume_found(v, np.ones(v.size, bool)) is None
    assert volume_found(v, v < 1.0) is None  # found less as cores grow: no limit
    assert core_volume_in3({"core_diameter_in": 1.0, "region_in": [24.0, 34.0]}) == \
        pytest.approx(np.pi / 4 * 10.0)
