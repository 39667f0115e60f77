"""CI-sized runs of the fleet benchmarks (benchmarks/bench_false_alarm.py,
benchmarks/bench_detection.py): they run the real command path on a bat or two and report
counts that add up. Verdict rates are the inspection's business, not asserted here."""

import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

import bench_detection  # noqa: E402
import bench_false_alarm  # noqa: E402
import fleet_runner  # noqa: E402

from updating.simulate.field_fleet import draw_case  # noqa: E402
from updating.simulate.integrity import INTEGRITY  # noqa: E402
from updating.simulate.nuisances import NUISANCES, OPTIONAL_NUISANCES  # noqa: E402


def test_verdict_status_reads_both_output_forms():
    assert fleet_runner.verdict_status({"status": "inconclusive", "altered": None}) == \
        "inconclusive"
    assert fleet_runner.verdict_status({"altered": True}) == "altered"
    assert fleet_runner.verdict_status({"altered": False}) == "not_altered"
    assert fleet_runner.verdict_status({"altered": None}) == "inconclusive"
    assert fleet_runner.verdict_status(None) == "refused"


def test_a_failing_bat_is_an_error_row_not_the_end(monkeypatch):
    def boom(job, retest_meta):
        raise ValueError("simulation broke")

    monkeypatch.setattr(bench_false_alarm, "inspect_job", boom)
    job = bench_false_alarm.plan(1, 0, 0, seed=1)[0]
    row = bench_false_alarm.run_job(job)
    assert row["status"] == "error" and "simulation broke" in row["error"]
    table, checks = bench_false_alarm.summarise([row])
    assert "| all nuisances | 1 | 0 | 0 | 0 | 0 | 1 |" in table
    assert any("failed on: 1" in text and not ok for text, ok in checks)


def test_plan_has_every_group():
    jobs = bench_false_alarm.plan(3, 2, 1, seed=1)
    groups = [j["group"] for j in jobs]
    assert groups.count("all nuisances") == 3
    for name in NUISANCES + OPTIONAL_NUISANCES:
        assert groups.count(f"alone: {name}") == 2
    for integ in INTEGRITY:
        assert groups.count(f"integrity: {integ}") == 1
    assert len({j["seed"] for j in jobs}) == len(jobs)


def table_counts(text: str) -> list[list[int]]:
    rows = []
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 8 and cells[1].isdigit():
            rows.append([int(c) for c in cells[1:7]])
    return rows


def test_false_alarm_bench_one_bat(tmp_path, capsys):
    out = tmp_path / "rows.json"
    bench_false_alarm.main(["--n", "1", "--alone", "0", "--integrity", "0", "--workers", "1",
                            "--out", str(out)])
    text = capsys.readouterr().out
    (bats, *counts), = table_counts(text)
    assert bats == 1 and sum(counts) == 1
    rows = json.loads(out.read_text())
    assert len(rows) == 1 and rows[0]["status"] in fleet_runner.STATUSES
    assert rows[0]["expected"] == "not_altered" and rows[0]["group"] == "all nuisances"
    assert re.search(r"clean bats called altered: \d/1", text)


def test_detection_bench_one_bat(tmp_path, capsys):
    out = tmp_path / "rows.json"
    assert bench_detection.main(["--bats", "1", "--diameters", "1.0", "--lengths", "10",
                                 "--kinds", "", "--lab-clean", "2", "--workers", "1",
                                 "--out", str(out)]) == 0
    text = capsys.readouterr().out
    rows = json.loads(out.read_text())
    assert [r["kind"] for r in rows] == ["none", "cork"]
    assert all(r["status"] in fleet_runner.STATUSES for r in rows)
    cork = rows[1]["truth"]
    a, b = cork["region_in"]
    assert cork["core_diameter_in"] == 1.0 and b - a == pytest.approx(10.0)
    assert "| 1.00 x 10 in | 1 |" in text and "clean re-tests: 1" in text
    # the lab's scale: a 1 x 10 in cork core (70 % of 7.9 in^3 of wood gone) is far beyond
    # what +-2 points of moisture move; the clean re-test is not
    said = [bench_detection.lab_verdicts(r["truth"], balance_limit_in=1.0) for r in rows]
    assert said[1]["scale"] and not said[0]["scale"]


def test_lab_rules_and_roc():
    case = draw_case(np.random.default_rng(1), "none", ("uniform_drift",))
    dw, dcg = bench_detection.lab_statistics(case.truth)
    drift = case.truth["drawn"]["uniform_drift"]["middle_pct"]
    assert dw == pytest.approx(0.01 * abs(drift), abs=0.004)  # 1 %/point, scale noise
    assert dcg < 0.2  # a uniform drift leaves the balance point
    assert bench_detection.roc_auc([0.1, 0.2], [0.3, 0.4]) == 1.0
    assert bench_detection.roc_auc([0.1, 0.3], [0.2, 0.3]) == pytest.approx(0.625)
