"""The command line reads the same everywhere: --version, an example under every command's
help, one default wood (stated, the same E/G for model, simulate and rig), messages naming the
key they are about, lab units at the edges."""

from __future__ import annotations

import json

import pytest

from batlab import __version__
from batlab.cli import COMMANDS, build_parser, main


def run_cli(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.strip() == f"batlab {__version__}"


@pytest.mark.parametrize("name", tuple(COMMANDS))
def test_every_command_has_an_example_in_its_help(name):
    sub = build_parser()._subparsers._group_actions[0].choices[name]
    text = sub.format_help()
    assert "example:\n  batlab " + name in text, text[-300:]
    for action in sub._actions:  # and every option says what it is
        if action.option_strings and action.dest != "help":
            assert action.help, f"{name} {action.option_strings[0]} has no help"
    example = text.split("example:\n")[1]
    assert max(len(line) for line in example.splitlines()) <= 100, example


def test_inspect_help_names_the_retest_once_per_form():
    """`inspect --help` shows its two forms, one a line, the re-test as RETEST in each, and
    no metavar spelt as its option's dest (issue 50)."""
    text = build_parser()._subparsers._group_actions[0].choices["inspect"].format_help()
    usage = text.split("\n\n")[0].splitlines()
    assert usage[1].strip().startswith("batlab inspect --serial S RETEST")
    assert usage[2].strip().startswith("batlab inspect --profile P --meta M --baseline B "
                                       "--retest RETEST")
    assert "FALSE_ALARM" not in text and "retest_file" not in text


def test_one_default_wood_stated_on_stderr(capsys):
    code, out, err = run_cli(["model", "--json", "--beam", "timoshenko"], capsys)
    assert code == 0
    assert "no --meta: the default wood, the paper's white birch" in err and "E/G 14" in err
    default = json.loads(out)
    _, out14, _ = run_cli(["model", "--json", "--beam", "timoshenko", "--e-over-g", "14"],
                          capsys)
    assert json.loads(out14)["frequencies_hz"] == default["frequencies_hz"]
    _, out26, _ = run_cli(["model", "--json", "--beam", "timoshenko", "--e-over-g", "2.6"],
                          capsys)
    assert json.loads(out26)["frequencies_hz"] != default["frequencies_hz"]  # E/G matters


def test_simulate_json_is_rounded_and_names_its_wood(tmp_path, capsys):
    code, out, err = run_cli(["simulate", "--out", tmp_path / "t.npz", "--points-in", "1,3,33",
                              "--fmax", "300", "--df", "2", "--seed", "1", "--json"], capsys)
    assert code == 0 and "the default wood" in err and "E/G 14" in err
    assert json.loads(out)["points_in"] == [1.0, 3.0, 33.0]


def test_meta_errors_name_the_key(tmp_path, capsys):
    meta = {"serial": "X", "species": "maple", "nominal_E_psi": "1.7e6 psi",
            "nominal_weight_density_lbf_in3": 0.02, "weight_lb": 1.9, "points_in": [1, 33]}
    (tmp_path / "m.json").write_text(json.dumps(meta))
    code, _, err = run_cli(["model", "--meta", tmp_path / "m.json"], capsys)
    assert code == 2
    assert (f"{tmp_path / 'm.json'}: key 'nominal_E_psi' must be a number (psi), not the "
            "text '1.7e6 psi'") in err
    meta.update(nominal_E_psi=1.7e6, points_in=[1, "two"])
    (tmp_path / "m.json").write_text(json.dumps(meta))
    code, _, err = run_cli(["model", "--meta", tmp_path / "m.json"], capsys)
    assert code == 2 and "key 'points_in'[1] must be a number" in err


def test_diagnose_plot_directory_checked_before_work(tmp_path, capsys):
    (tmp_path / "f").write_text("x")
    code, out, err = run_cli(["diagnose", "--profile", "data_samples/smooth_bat/profile.csv",
                              "--meta", "data_samples/smooth_bat/meta.json", "--frf",
                              "data_samples/smooth_bat/baseline.uff", "--plots",
                              tmp_path / "f" / "plots"], capsys)
    assert code == 2 and out == "" and "--plots destination not writable" in err
