"""`batlab simulate` writes a contract-form UFF test; the samples are what the script makes."""

import json
import shlex
from pathlib import Path

import numpy as np
import pytest
import pyuff

from batlab.cli import main
from ema.io.frf_io import read_test

SAMPLES = Path(__file__).resolve().parent.parent / "data_samples"


def test_simulate_writes_contract_uff(tmp_path, capsys):
    out = tmp_path / "t.uff"
    code = main(["simulate", "--out", str(out), "--seed", "4", "--df", "2", "--points-in",
                 "1,5,9,13,17,21,25,29,32", "--alter", "cork:depth=10,d=1,ratio=0.33", "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    test = read_test(out)
    assert test.frf.shape == (1601, 1, 9)
    assert test.quantity == "accelerance"
    assert test.response_nodes[0] == summary["driving_point_node"]
    assert test.node_x_m[int(test.response_nodes[0])] == pytest.approx(32 * 0.0254)
    sets = pyuff.UFF(str(out)).read_sets()
    types = [s["type"] for s in sets]
    assert types[:2] == [164, 15] and types.count(58) == 9
    assert all(s["func_type"] == 4 and s["rsp_node"] == test.response_nodes[0]
               for s in sets if s["type"] == 58)


def test_simulate_bad_points(tmp_path, capsys):
    assert main(["simulate", "--out", str(tmp_path / "x.uff"), "--points-in", "1,a"]) == 2
    assert "--points-in" in capsys.readouterr().err
    assert not (tmp_path / "x.uff").exists()


def test_sample_is_what_the_script_makes(tmp_path, monkeypatch, capsys):
    script = (SAMPLES / "make_samples.sh").read_text()
    common = shlex.split(script.split('common="')[1].split('"')[0])
    monkeypatch.chdir(SAMPLES)
    out = tmp_path / "baseline.uff"
    args = ["simulate", "--profile", "paper_bat/profile.csv", "--meta", "paper_bat/meta.json",
            "--beam", "euler", "--e-over-g", "2.6", *common, "--seed", "1", "--out", str(out)]
    assert main(args) == 0
    # the same seed gives the same test, to the round-off of the suspension modes (their
    # eigenvalues are ~1e-11 of the largest; BLAS and numpy versions reorder sums): 1e-4
    # relative, or 1e-7 of the largest FRF value near anti-resonances
    ours, sample = read_test(out), read_test(SAMPLES / "paper_bat" / "baseline.uff")
    atol = 1e-7 * np.abs(sample.frf).max()
    np.testing.assert_allclose(ours.frf, sample.frf, rtol=1e-4, atol=atol)
    assert ours.node_x_m == sample.node_x_m
    test = read_test(SAMPLES / "paper_bat" / "corked.uff")
    assert np.all(np.isfinite(test.frf)) and test.frf.shape == (3201, 1, 17)


def test_simulate_case_writes_a_labs_files(tmp_path, capsys):
    folder = tmp_path / "bat"
    assert main(["simulate", "--case", "-o", str(folder), "--kind", "cork", "--nuisances",
                 "moisture,cup", "--seed", "3", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["expected"] == "altered"
    names = {"profile.csv", "meta.json", "baseline.uff", "retest.uff", "retest.json",
             "truth.json"}
    assert {p.name for p in folder.iterdir()} == names
    truth = json.loads((folder / "truth.json").read_text())
    assert truth["kind"] == "cork" and set(truth["drawn"]) >= {"moisture", "cup"}
    meta = json.loads((folder / "meta.json").read_text())
    assert read_test(folder / "retest.uff").frf.shape[2] == len(meta["points_in"])


def test_simulate_case_bad_nuisance(tmp_path, capsys):
    assert main(["simulate", "--case", "-o", str(tmp_path / "x"), "--nuisances", "bogus"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bogus" in err[0]
    assert not (tmp_path / "x").exists()


def test_case_names_the_bat_in_words():
    """An unaltered simulated bat is "an unaltered bat", never "a none bat" (issue 50)."""
    from batlab.pipeline.bench import bat_words

    assert bat_words("none") == "an unaltered bat"
    assert bat_words("cork") == "a cork bat"
    assert bat_words("oak") == "an oak bat"
