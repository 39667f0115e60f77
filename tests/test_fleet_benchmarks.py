"""CI-sized runs of the fleet benchmarks' machinery (batlab.fleet with the scoring of
updating.simulate): the real command path on a bat or two, counts that add up. Verdict rates
are the inspection's business, not asserted here."""

import re

import numpy as np
import pytest

from batlab.fleet import jobs
from batlab.fleet.runner import fleet_map
from updating.simulate.detection import detection_report
from updating.simulate.field_fleet import draw_case
from updating.simulate.integrity import INTEGRITY
from updating.simulate.lab_methods import lab_statistics, lab_verdicts
from updating.simulate.nuisances import NUISANCES, OPTIONAL_NUISANCES
from updating.simulate.scoring import (
    STATUSES,
    false_alarm_plan,
    false_alarm_summary,
    roc_auc,
    verdict_status,
)


def test_verdict_status_reads_both_output_forms():
    assert verdict_status({"status": "inconclusive", "altered": None}) == "inconclusive"
    assert verdict_status({"altered": True}) == "altered"
    assert verdict_status({"altered": False}) == "not_altered"
    assert verdict_status({"altered": None}) == "inconclusive"
    assert verdict_status(None) == "refused"


def test_a_failing_bat_is_an_error_row_not_the_end(monkeypatch):
    def boom(job, retest_meta):
        raise ValueError("simulation broke")

    monkeypatch.setattr(jobs, "inspect_clean_bat", boom)
    job = false_alarm_plan(1, 0, 0, seed=1)[0]
    row = jobs.false_alarm_row(job)
    assert row["status"] == "error" and "simulation broke" in row["error"]
    table, checks = false_alarm_summary([row])
    assert "| all nuisances | 1 | 0 | 0 | 0 | 0 | 1 |" in table
    assert any("failed on: 1" in text and not ok for text, ok in checks)


def test_plan_has_every_group():
    plan = false_alarm_plan(3, 2, 1, seed=1)
    groups = [j["group"] for j in plan]
    assert groups.count("all nuisances") == 3
    for name in NUISANCES + OPTIONAL_NUISANCES:
        assert groups.count(f"alone: {name}") == 2
    for integ in INTEGRITY:
        assert groups.count(f"integrity: {integ}") == 1
    assert len({j["seed"] for j in plan}) == len(plan)


def table_counts(text: str) -> list[list[int]]:
    rows = []
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 8 and cells[1].isdigit():
            rows.append([int(c) for c in cells[1:7]])
    return rows


def test_false_alarm_one_bat_through_the_command():
    rows = fleet_map(jobs.false_alarm_row, false_alarm_plan(1, 0, 0, seed=1), 1, "bat")
    table, checks = false_alarm_summary(rows)
    (bats, *counts), = table_counts(table)
    assert bats == 1 and sum(counts) == 1
    assert len(rows) == 1 and rows[0]["status"] in STATUSES
    assert rows[0]["expected"] == "not_altered" and rows[0]["group"] == "all nuisances"
    assert any(re.search(r"clean bats called altered: \d/1", text) for text, _ in checks)


def test_detection_one_bat_through_the_registry():
    plan = jobs.detection_jobs(1, 2, [(1.0, 10.0)], 0.3, [], no_retest_meta=False, records=1)
    rows = [r for bat in fleet_map(jobs.detection_rows, plan, 1, "bat") for r in bat]
    assert [r["kind"] for r in rows] == ["none", "cork"]
    assert all(r["status"] in STATUSES for r in rows)
    assert [r["truth"]["grid"] for r in rows] == [False, True]
    # both tests' records reached the files: the re-tests share the bat's readings
    assert all(len(r["truth"]["lab_records"]["retest"]["moisture"]) == 3 for r in rows)
    cork = rows[1]["truth"]
    a, b = cork["region_in"]
    assert cork["core_diameter_in"] == 1.0 and b - a == pytest.approx(10.0)
    text = detection_report(rows, balance_limit_in=1.0)
    assert "| 1.00 x 10 in | 1 |" in text and "clean re-tests: 1" in text
    assert "90 % found from not fitted (all or none found)" in text  # one core cannot fit
    # the lab's scale: a 1 x 10 in cork core (70 % of 7.9 in^3 of wood gone) is far beyond
    # what +-2 points of moisture move; the clean re-test is not
    said = [lab_verdicts(r["truth"], balance_limit_in=1.0) for r in rows]
    assert said[1]["scale"] and not said[0]["scale"]


def test_lab_rules_and_roc():
    case = draw_case(np.random.default_rng(1), "none", ("uniform_drift",))
    dw, dcg = lab_statistics(case.truth)
    drift = case.truth["drawn"]["uniform_drift"]["middle_pct"]
    assert dw == pytest.approx(0.01 * abs(drift), abs=0.004)  # 1 %/point, scale noise
    assert dcg < 0.2  # a uniform drift leaves the balance point
    assert roc_auc([0.1, 0.2], [0.3, 0.4]) == 1.0
    assert roc_auc([0.1, 0.3], [0.2, 0.3]) == pytest.approx(0.625)
