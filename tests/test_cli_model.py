"""`batlab model` end to end, and its handling of bad profiles."""

import json
import subprocess
import sys

import pytest

from batlab.cli import main


def run_cli(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_model_json_paper_bat(capsys):
    code, out, _ = run_cli(["model", "--profile", "data_samples/paper_bat/profile.csv", "--json"],
                           capsys)
    assert code == 0
    res = json.loads(out)
    assert res["ndof"] == 68
    assert res["weight_lb"] == pytest.approx(2.1176, abs=1e-4)
    assert res["frequencies_hz"][:2] == [0.0, 0.0]
    assert res["frequencies_hz"][2] == pytest.approx(141.5, rel=2e-3)
    assert res["frequencies_hz"] == sorted(res["frequencies_hz"])
    assert len(res["suggested_points_in"]) == 16


def test_model_timoshenko_lowers_frequencies(capsys):
    _, out_e, _ = run_cli(["model", "--json"], capsys)
    _, out_t, _ = run_cli(["model", "--json", "--beam", "timoshenko", "--e-over-g", "14"], capsys)
    fe, ft = json.loads(out_e)["frequencies_hz"], json.loads(out_t)["frequencies_hz"]
    drops = [1 - t / e for e, t in zip(fe[2:6], ft[2:6], strict=True)]
    assert all(d > 0 for d in drops) and drops[3] > 5 * drops[0]


BAD = {
    "decreasing": ("x_in,diameter_in\n0,1.2\n5,1.0\n3,2.0\n", "decreases"),
    "negative": ("x_in,diameter_in\n0,1.2\n5,-1.0\n", "positive"),
    "one_station": ("x_in,diameter_in\n0,1.2\n", "two stations"),
    "missing_column": ("x_in,dia\n0,1.2\n5,1.0\n", "missing column"),
    "not_numbers": ("x_in,diameter_in\n0,1.2\n5,abc\n", "not two numbers"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_profile_one_line_error_exit_2(tmp_path, case):
    text, words = BAD[case]
    path = tmp_path / f"{case}.csv"
    path.write_text(text)
    proc = subprocess.run([sys.executable, "-m", "batlab", "model", "--profile", str(path)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and words in lines[0]


def test_missing_profile_file(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "batlab", "model", "--profile",
                           str(tmp_path / "nope.csv")], capture_output=True, text=True)
    assert proc.returncode == 2 and "nope.csv" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
