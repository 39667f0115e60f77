"""A band whose top cuts a pair of bending planes, and a legal grip (issue 36's accusation).

Built in the project's simulator (``updating.simulate.wide.band_edge_case``): both tests
tapped 10-25 deg off the first grain plane, the band's top between the two planes' members
of the highest mode in it, so that mode is seen only through the weaker plane's member;
pine tar on the handle at the re-test, with moisture, temperature and a replaced
accelerometer.
Through the whole stateless path (files, modal fits, calibration, inspection): not altered,
the grip named as legal, and the weaker plane's mode said to be left out.
"""

from __future__ import annotations

import pytest

import batlab.pipeline as pipeline
from updating.simulate import wide
from updating.simulate.field_fleet import write_case


@pytest.mark.parametrize("seed", [100_001])
def test_a_band_edge_pair_and_a_grip_are_not_called_altered(tmp_path, seed):
    case = wide.band_edge_case(seed, serial=f"BE-{seed}")
    edge = case.truth["drawn"]["band_edge"]
    assert edge["cuts_baseline"] and edge["cuts_retest"]
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
        # the weaker plane's member carries no verdict: left out and said, or not paired
        weak_hz = edge["baseline_pair_hz"][0]
        paired = [m.baseline_hz for m in v.modes if abs(m.baseline_hz / weak_hz - 1) < 0.02]
        said = any("left out" in r and f"mode {edge['mode']}" in r for r in v.reasons)
        assert said or not paired, (paired, v.reasons)
