"""`batlab fleet`: its seeds, its bound, its clean re-tests, and a calibration on a real
``distributed.LocalCluster`` (the same seed twice gives the same JSON)."""

import json

import numpy as np
import pytest
from scipy.stats import binom

import batlab.pipeline as pipeline
from batlab.cli import main
from batlab.fleet.calibrate import BatSpec, child_seed, read_rows, same_row, summary, upper95
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


def _calibrate(capsys, n: int, seed: int, *more) -> tuple[dict, str]:
    code = main(["fleet", "calibrate", "--profile", str(BUILTIN / "profile.csv"), "--meta",
                 str(BUILTIN / "meta.json"), "--n", str(n), "--seed", str(seed), "--json",
                 *more])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "clean bat: " in err and "a minute" in err  # progress: count, rate, time
    return json.loads(out), err


def _rows(path) -> list[dict]:
    """The rows of a calibration's file, in index order (it holds them in arrival order)."""
    return sorted((json.loads(line) for line in path.read_text().splitlines()),
                  key=lambda r: r["index"])


def test_calibrate_on_a_local_cluster_resumed_the_same(capsys, tmp_path):
    """Two bats, then a third by --resume: bat 2 inspected again agrees with its row (the
    same seed, the same answer; its row said another code judged it, and that is said with
    both versions), the three stored as the built-in model's null (--store), from which a
    real inspection of a bat of that model states its chance; a row another run made is
    refused, naming the file."""
    from batlab.version import code_version

    rows, db = tmp_path / "rows.jsonl", tmp_path / "league.sqlite"
    first, err = _calibrate(capsys, 2, 7, "-o", str(rows))
    assert first["n"] == 2 and first["serial"] == "DEMO-34A"
    counted = first["false_alarms"] + first["inconclusive"] + first["not_altered"]
    assert counted + first["refused"] == 2
    assert first["false_alarm_upper95"] == pytest.approx(upper95(first["false_alarms"], 2))
    assert first["core_s_per_bat"] > 0 and "core-s a bat" in err
    assert first["codes"] == {code_version(): 2}
    two = _rows(rows)
    assert [r["index"] for r in two] == [1, 2] and all(r["code"] == code_version() for r in two)
    two[1]["code"] = "0.1.0+gdeadbeef1"  # as if an older batlab had judged re-test 2
    rows.write_text("".join(json.dumps(r) + "\n" for r in two))
    more, err = _calibrate(capsys, 3, 7, "-o", str(rows), "--resume", "--store", "--db",
                           str(db))
    assert "re-test 2 judged again under other code (stored by batlab 0.1.0+gdeadbeef1, " \
           f"judged again by batlab {code_version()})" in err
    three = _rows(rows)
    assert [r["index"] for r in three] == [1, 2, 3] and three[:2] == two
    assert more["n"] == 3 and more["false_alarm_upper95"] == pytest.approx(
        upper95(more["false_alarms"], 3))
    assert more["codes"] == {code_version(): 2, "0.1.0+gdeadbeef1": 1}
    stored = more["stored"]
    code = main(["demo", "-o", str(tmp_path / "demo"), "--db", str(db), "--json"])
    verdict = json.loads(capsys.readouterr().out)
    assert code == 0 and verdict["chance"]["source"] == "calibration"
    cal = verdict["chance"]["calibration"]
    assert (cal["model"], cal["n"], cal["record_seq"]) == (stored["model"], 3,
                                                          stored["record_seq"])
    assert cal["false_alarm_upper95"] == more["false_alarm_upper95"]
    assert verdict["code"] == code_version()
    # 3 re-tests cannot show a chance below 0.1 %: stated from them, decided on the nominal
    assert verdict["chance"]["decided_on"] == "nominal"
    assert any("3 re-tests are too few to measure a chance as small as the decision's level"
               in r for r in verdict["reasons"]), verdict["reasons"]
    three[2]["F"] = 2.0 * (three[2]["F"] or 1.0) + 1.0  # as if another seed had made it
    rows.write_text("".join(json.dumps(r) + "\n" for r in three))
    code = main(["fleet", "calibrate", "--profile", str(BUILTIN / "profile.csv"), "--meta",
                 str(BUILTIN / "meta.json"), "--n", "3", "--seed", "7", "-o", str(rows),
                 "--resume"])
    err = capsys.readouterr().err
    assert code == 2 and f"{rows}: re-test 3 was stored as" in err


def test_read_rows_leaves_out_a_last_line_cut_short(tmp_path):
    path = tmp_path / "rows.jsonl"
    rows = [{"index": i, "status": "not_altered", "F": 1.0 + i} for i in (1, 3, 2, 9)]
    path.write_text("".join(json.dumps(r) + "\n" for r in rows) + '{"index": 4, "sta')
    kept, cut = read_rows(str(path), 5)
    assert [r["index"] for r in kept] == [1, 2, 3] and cut == 1
    path.write_text('{"index": 1\n' + json.dumps(rows[0]) + "\n")
    with pytest.raises(ValueError, match="line 1 is not a calibration row"):
        read_rows(str(path), 5)


def test_same_row_reads_status_and_f():
    row = {"index": 1, "status": "not_altered", "F": 2.5}
    assert same_row(row, dict(row, F=2.5 * (1 + 1e-9)))
    assert not same_row(row, dict(row, F=2.6))
    assert not same_row(row, dict(row, status="inconclusive"))
    assert same_row(dict(row, F=None), dict(row, F=None))
    nan = dict(row, status="inconclusive", F=float("nan"))  # judged before the F test
    assert same_row(json.loads(json.dumps(nan)), nan)
    assert not same_row(nan, dict(nan, F=2.5)) and not same_row(dict(row, F=None), row)


def test_plain_heap_sets_glibcs_thresholds_once():
    import sys

    from batlab.fleet.cluster import on_plain_heap, plain_heap

    if not sys.platform.startswith("linux"):
        pytest.skip("glibc's mallopt: Linux only")
    assert plain_heap() is True and plain_heap() is True
    assert on_plain_heap(lambda x: 2 * x, 21) == 42


def test_the_verdict_does_not_need_the_element_map(tmp_path):
    """A calibration skips the MSSO map: the verdict, its statistic, reasons and finding
    are those of the inspection that draws it (only ``details.msso`` differs)."""
    from dataclasses import replace

    from batlab.fleet.calibrate import registration
    from updating.inspect.retest_meta import conditions_from_dict
    from updating.simulate.virtual_bat import simulate_test

    spec = BatSpec(str(BUILTIN / "profile.csv"), str(BUILTIN / "meta.json"), 7)
    reg = registration(spec)
    retest = draw_retest(np.random.default_rng(child_seed(7, 3)), reg.bat)
    path = tmp_path / "retest.npz"
    pipeline.write_frf(path, simulate_test(retest.bat, reg.bat.freq_hz, seed=retest.noise_seed))
    case = replace(reg.case, retest=pipeline.fit_file(path.name, pipeline.read_frf(path),
                                                      reg.case.weight_kg))
    cond = conditions_from_dict(retest.retest_meta, "retest.json")
    drawn = pipeline.judge(case, 0.01, cond).verdict
    bare = pipeline.judge(case, 0.01, cond, with_map=False).verdict
    assert drawn.details.fit.msso.result is not None
    assert bare.details.fit.msso.result is None
    assert bare.statistic == drawn.statistic and bare.reasons == drawn.reasons
    assert pipeline.contract_dict("S", bare) == pipeline.contract_dict("S", drawn)


def test_resume_takes_off_only_a_cut_last_line(tmp_path):
    """``--resume`` on a file killed mid-line: the cut line goes (atomically), every complete
    row stays, those beyond ``--n`` too; the rows kept are re-tests 1..n."""
    import argparse

    from batlab.commands.fleet import _stored_rows

    path = tmp_path / "rows.jsonl"
    rows = [{"index": i, "status": "not_altered", "F": 1.0 + i} for i in (1, 2, 7)]
    path.write_text("".join(json.dumps(r) + "\n" for r in rows) + '{"index": 3, "st')
    said = []
    kept = _stored_rows(argparse.Namespace(resume=True, out=str(path), n=5), said.append)
    assert [r["index"] for r in kept] == [1, 2] and "cut short" in said[0]
    assert [json.loads(line)["index"] for line in path.read_text().splitlines()] == [1, 2, 7]
    assert path.read_text().endswith("\n") and not list(tmp_path.glob("*.tmp*"))
