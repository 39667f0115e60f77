"""A band whose top cuts a pair of bending planes, and a legal grip (issue 36's accusation).

Built in the project's simulator: the re-test and the baseline tapped 17 and 20 deg off the
first grain plane, the band's top between the two planes' members of the highest mode in
it, so that mode is seen only through the weaker plane's member; pine tar on the handle at
the re-test, with moisture, temperature, a re-mounted or replaced accelerometer and noise.
Through the whole stateless path (files, modal fits, calibration, inspection): not altered,
the grip named as legal, and the weaker plane's mode said to be left out.
"""

from __future__ import annotations

import numpy as np
import pytest

import batlab.pipeline as pipeline
from updating.simulate.field_fleet import band_edge_case, write_case


@pytest.mark.parametrize("seed", [1])
def test_a_band_edge_pair_and_a_grip_are_not_called_altered(tmp_path, seed):
    case = band_edge_case(np.random.default_rng(seed), serial=f"BE-{seed}")
    edge = case.truth["drawn"]["band_edge"]
    assert edge["lower_member_hz"] < case.freq_hz[-1] < edge["upper_member_hz"]
    paths = write_case(case, tmp_path, seed)
    for meta in (paths["retest_meta"], None):
        res = pipeline.inspect_files(paths["profile"], paths["meta"], paths["baseline"],
                                     paths["retest"], 0.01, retest_meta_path=meta,
                                     with_map=False)
        v = res.verdict
        assert v.altered is False, v.reasons
        assert v.finding is not None and v.finding.kind == "handle_substance"
        assert v.finding.legal
        grams = 1e3 * v.finding.reading["added_mass_kg"]
        truth_g = case.truth["finding"]["reading"]["added_mass_g"]
        assert grams == pytest.approx(truth_g, abs=3.0)
        assert any("left out" in r and f"mode {edge['mode']}" in r for r in v.reasons)
