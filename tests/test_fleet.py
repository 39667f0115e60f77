"""`batlab fleet`: its seeds, its bound, its clean re-tests, and a calibration on a real
``distributed.LocalCluster`` (the same seed twice gives the same JSON)."""

import json

import numpy as np
import pytest
from scipy.stats import binom

import batlab.pipeline as pipeline
from batlab.cli import main
from batlab.fleet.calibrate import BatSpec, child_seed, summary, upper95
from batlab.fleet.clean_retests import draw_bat, draw_retest
from batlab.fleet.inspect_fleet import retest_jobs

BUILTIN = pipeline.bench.builtin_dir()


def test_child_seed_is_the_spawned_child():
    kids = np.random.SeedSequence(2026).spawn(7)
    for i in (0, 3, 6):
        assert np.array_equal(child_seed(2026, i).generate_state(4), kids[i].generate_state(4))


@pytest.mark.parametrize("n", [1, 8, 3000, 30000])
def test_upper_bound_at_zero_alarms_is_the_closed_form(n):
    assert upper95(0, n) == pytest.approx(1 - 0.05 ** (1 / n), rel=1e-9)
    if n >= 3000:  # the rule of three
        assert upper95(0, n) == pytest.approx(3 / n, rel=0.01)


@pytest.mark.parametrize("k, n", [(1, 50), (3, 1000), (10, 200)])
def test_upper_bound_leaves_five_percent_below(k, n):
    """Clopper-Pearson: at the bound, k or fewer alarms in n bats has probability 5 %."""
    assert binom.cdf(k, n, upper95(k, n)) == pytest.approx(0.05, rel=1e-6)
    assert upper95(n, n) == 1.0


def test_summary_counts_alarms_and_reads_the_tail():
    rng = np.random.default_rng(5)
    n, hidden = 40, sorted(rng.choice(40, size=3, replace=False).tolist())
    rows = [{"index": i + 1, "grip": None, "status": "altered" if i in hidden else
             "not_altered", "F": 30.0 + i if i in hidden else float(rng.uniform(0, 3)),
             "p": 1e-6 if i in hidden else float(rng.uniform(0.05, 1))} for i in range(n)]
    rows[int(rng.choice([i for i in range(n) if i not in hidden]))].update(
        status="inconclusive", F=float("nan"), p=float("nan"))  # judged before the F test
    out = summary(rows, BatSpec("profile.csv", "meta.json", 1))
    assert out["inconclusive"] == 1 and np.isfinite(out["tail"]["F_quantiles"]["50"])
    assert out["false_alarms"] == 3 and out["n"] == n
    assert out["alarm_indices"] == [i + 1 for i in hidden]
    assert sorted(r["index"] for r in out["tail"]["largest_F"][:3]) == [i + 1 for i in hidden]
    assert out["false_alarm_upper95"] == pytest.approx(upper95(3, n))


def _bat():
    profile = pipeline.bat_profile(BUILTIN / "profile.csv")
    nominal = pipeline.wood(BUILTIN / "meta.json", None)
    meta = pipeline.read_meta_dict(BUILTIN / "meta.json")
    return draw_bat(np.random.default_rng(11), profile, nominal, meta), meta


def test_the_bat_weighs_what_meta_json_says():
    bat, meta = _bat()
    # density matched to the registered weight (billet gradients and the cupped end
    # included): the scale's reading within 4 sigma of 0.002 lb; the drawn E within +-15 %
    assert bat.meta["weight_lb"] == pytest.approx(meta["weight_lb"], abs=0.008)
    assert 0.85 <= bat.drawn["e_scale"] <= 1.15
    assert bat.meta["serial"] == meta["serial"]


def test_a_grip_adds_its_mass_to_the_scale_reading():
    """A re-test's retest.json weight is the baseline's plus the grip's mass and the
    moisture's, read on a scale (0.002 lb)."""
    bat, _ = _bat()
    seen = set()
    for s in range(40):
        rt = draw_retest(np.random.default_rng(s), bat)
        again = draw_retest(np.random.default_rng(s), bat)
        assert rt.retest_meta == again.retest_meta and rt.grip == again.grip
        added_g = sum(1e3 * c.added_mass_kg for c in rt.bat.local_changes)
        moist = 0.01 * rt.drawn["moisture"]["middle_pct"]  # +1 % mass a point, roughly
        gain_g = (rt.retest_meta["weight_lb"] - bat.meta["weight_lb"]) * 453.59237
        assert gain_g == pytest.approx(added_g + moist * 453.59237 * bat.meta["weight_lb"],
                                       abs=5.0 + 0.6 * abs(moist) * 850)
        assert (rt.grip is None) == (added_g == 0.0)
        seen.add(rt.grip)
    assert seen == {None, "pine_tar", "grip_tape", "spray"}


def test_fleet_folder_lists_uff_with_their_json(tmp_path):
    (tmp_path / "B-2.uff").write_bytes(b"")
    (tmp_path / "A-1.uff").write_bytes(b"")
    (tmp_path / "A-1.json").write_text("{}")
    jobs = retest_jobs(tmp_path)
    assert [j.serial for j in jobs] == ["A-1", "B-2"]
    assert jobs[0].retest_meta_path.endswith("A-1.json") and jobs[1].retest_meta_path is None
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="no SERIAL.uff"):
        retest_jobs(tmp_path / "empty")


def _calibrate(capsys, n: int, seed: int) -> dict:
    code = main(["fleet", "calibrate", "--profile", str(BUILTIN / "profile.csv"), "--meta",
                 str(BUILTIN / "meta.json"), "--n", str(n), "--seed", str(seed), "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "clean bat: " in err and "a minute" in err  # progress: count, rate, time
    return json.loads(out)


def test_calibrate_on_a_local_cluster_twice_the_same(capsys):
    first = _calibrate(capsys, 2, 7)
    assert first["n"] == 2 and first["serial"] == "DEMO-34A"
    counted = first["false_alarms"] + first["inconclusive"] + first["not_altered"]
    assert counted + first["refused"] == 2
    assert first["false_alarm_upper95"] == pytest.approx(upper95(first["false_alarms"], 2))
    assert _calibrate(capsys, 2, 7) == first
