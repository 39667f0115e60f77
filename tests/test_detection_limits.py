"""Detection limits (updating.simulate.limits): change sizes of drawn bats, the 90 % size
from a known detection curve, and the per-kind table's counts on hand-made rows. No
inspection runs here."""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.simulate.field_fleet import draw_case
from updating.simulate.limits import change_details, change_size, found_from, limits_table

sizes_st = st.lists(st.floats(0.01, 100.0, allow_nan=False), min_size=1, max_size=60,
                    unique=True)


@settings(max_examples=200, deadline=None)
@given(sizes=sizes_st, t=st.floats(0.0, 101.0), data=st.data())
def test_a_step_detection_curve_gives_its_90_percent_size(sizes, t, data):
    """Every bat of size >= t found, none below: the tail from the K-th largest miss is
    |A| / (|A| + K) found, >= 90 % exactly when 9 K <= |A|."""
    sizes = data.draw(st.permutations(sizes))
    found = [s >= t for s in sizes]
    above = sorted(s for s in sizes if s >= t)
    below = sorted((s for s in sizes if s < t), reverse=True)
    got = found_from(sizes, found)
    if len(above) < 3:
        assert got is None
        return
    k = min(len(below), len(above) // 9)
    assert got == (below[k - 1] if k else above[0])


@settings(max_examples=100, deadline=None)
@given(sizes=sizes_st, t=st.floats(0.0, 101.0))
def test_all_of_the_tail_found_recovers_the_threshold(sizes, t):
    found = [s >= t for s in sizes]
    above = [s for s in sizes if s >= t]
    got = found_from(sizes, found, rate=1.0, min_bats=1)
    assert got == (min(above) if above else None)


def test_all_found_none_found_and_too_few_bats():
    sizes = [5.0, 1.0, 3.0, 2.0]
    assert found_from(sizes, [True] * 4) == 1.0
    assert found_from(sizes, [False] * 4) is None
    assert found_from([4.0, 2.0], [True, True]) is None
    assert found_from([4.0, 2.0], [True, True], min_bats=2) == 2.0
    assert found_from([], []) is None


def test_tied_sizes_count_together():
    # from 2: 3 of 4 found (75 %); from 3: 2 of 2, too few; so rate 0.75 gives 2
    sizes, found = [2.0, 2.0, 3.0, 3.0], [True, False, True, True]
    assert found_from(sizes, found) is None
    assert found_from(sizes, found, rate=0.75) == 2.0


def drawn(kind, seed):
    return draw_case(np.random.default_rng(seed), kind).truth


@pytest.mark.parametrize("seed", [1, 7])
def test_change_size_reads_each_kinds_own_numbers(seed):
    nails = drawn("nails", seed)
    size, unit = change_size(nails)
    reading = nails["finding"]["reading"]
    assert (size, unit) == (reading["net_added_mass_g"], "g net")
    assert 0 < size < change_details(nails)["steel_g"] == reading["added_mass_g"]

    shaved = drawn("shaved", seed)
    reading = shaved["finding"]["reading"]
    assert change_size(shaved) == (reading["removed_mass_g"], "g removed")
    assert change_details(shaved) == {"diameter_lost_in": reading["diameter_lost_in"],
                                      "length_in": reading["length_in"]}

    wax = drawn("wax", seed)
    assert change_size(wax) == (wax["finding"]["reading"]["added_mass_g"], "g")
    assert 3.0 <= change_size(wax)[0] <= 15.0

    cork = drawn("cork", seed)
    (x0, x1), d = cork["region_in"], cork["core_diameter_in"]
    size, unit = change_size(cork)
    assert unit == "in^3" and size == pytest.approx(np.pi / 4 * d**2 * (x1 - x0), rel=1e-12)
    assert change_details(cork) == pytest.approx({"d_in": d, "length_in": x1 - x0})

    assert change_size(drawn("none", seed)) is None
    assert change_size(drawn("pine_tar", seed)) is None
    assert change_size(drawn("tar_past_18", seed)) is None


def lab(dw_lb=0.0, dcg_in=0.0):
    return {"baseline_lb": 2.0, "retest_lb": 2.0 + dw_lb, "baseline_balance_in": 22.0,
            "retest_balance_in": 22.0 + dcg_in}


def wax_truth(mass_g, dw_lb, dcg_in):
    return {"kind": "wax", "altered": True, "lab_readings": lab(dw_lb, dcg_in),
            "finding": {"reading": {"added_mass_g": mass_g}}}


def hand_made_rows():
    """Wax 2, 4, 6, 8 g: batlab finds 4-8 g with retest.json, 4 g of the two without, 6 g
    of the two with the re-test profile; the scale (> 2.4 % of 2 lb) only the 8 g bat; the
    balance point (limit 0.1 in) 6 and 8 g. Two clean bats, one called altered with
    retest.json and moved 0.2 in on the balance, neither with the profile."""
    wax = {1: (2.0, 0.0, 0.0), 2: (4.0, 0.0, 0.05), 3: (6.0, 0.01, 0.2), 4: (8.0, 0.06, 0.2)}
    rows = []
    for seed, (m, dw, dcg) in wax.items():
        truth = wax_truth(m, dw, dcg)
        rows.append({"kind": "wax", "seed": seed, "with_meta": True, "truth": truth,
                     "status": "altered" if m > 3 else "not_altered"})
        if seed <= 2:
            rows.append({"kind": "wax", "seed": seed, "with_meta": False, "truth": truth,
                         "status": "altered" if m == 4.0 else "inconclusive"})
        if seed in (2, 3):
            rows.append({"kind": "wax", "seed": seed, "with_meta": True, "with_profile": True,
                         "truth": truth, "status": "altered" if m == 6.0 else "not_altered"})
    for seed, status, dcg in ((10, "altered", 0.2), (11, "not_altered", 0.0)):
        truth = {"kind": "none", "altered": False, "lab_readings": lab(0.0, dcg)}
        rows += [{"kind": "none", "seed": seed, "with_meta": meta, "truth": truth,
                  "status": status if meta else "not_altered"} for meta in (True, False)]
        rows.append({"kind": "none", "seed": seed, "with_meta": True, "with_profile": True,
                     "truth": truth, "status": "not_altered"})
    rows.append({"kind": "wax", "seed": 99, "with_meta": True, "status": "error",
                 "error": "simulation broke"})
    return rows


def cells(table, kind):
    line = next(s for s in table.splitlines() if s.startswith(f"| {kind} |"))
    return [c.strip() for c in line.strip("|").split("|")]


def test_limits_table_counts_hand_made_rows():
    table = limits_table(hand_made_rows(), balance_limit_in=0.1)
    assert cells(table, "wax") == ["wax", "4", "2-8 g", "3/4", "1/2", "1/2", "1/4", "2/4",
                                   "4 g", "-", "-", "-", "-"]
    assert cells(table, "none") == ["none", "2", "false alarms (called altered)", "1/2", "0/2",
                                    "0/2", "0/2", "1/2", "-", "-", "-", "-", "-"]
    assert "balance limit 0.100 in" in table


def load_bench():
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_rulebook.py"
    spec = importlib.util.spec_from_file_location("bench_rulebook", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_bench_summary_prints_the_limits(tmp_path, capsys, monkeypatch):
    bench = load_bench()
    monkeypatch.setattr(bench, "clean_balance_limit_in", lambda n, seed: 0.1 if n == 7 else 9.0)
    rows = [r for r in hand_made_rows() if "truth" in r]
    for r in rows:
        r.update(seconds=1.0, region_ok=None, kind_ok=None)
    path = tmp_path / "rows.jsonl"
    path.write_text("\n".join(json.dumps(r) for r in rows) + "\n")
    assert bench.main(["--summary", str(path), "--balance-clean", "7"]) == 0
    err = capsys.readouterr().err
    assert "## Detection limits" in err
    assert cells(err.split("## Detection limits")[1], "wax")[3:8] == ["3/4", "1/2", "1/2", "1/4",
                                                                     "2/4"]
