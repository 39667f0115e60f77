"""One command language (#27): the option names of every command, read from its --help."""

from __future__ import annotations

import json
import re

import pytest

from batlab.cli import COMMANDS, build_parser, main

WRITES = {"acquire", "demo", "export", "fit", "fleet", "inspect", "registry", "report",
          "simulate"}
"""Commands that write a file or a folder the user names (``-o/--out``)."""
PLOTS = {"diagnose", "fit", "inspect", "paper", "report"}
"""Commands that write figures (``--plots DIR``)."""
OLD = ("--output", "--plot")
"""Old spellings that no --help lists (they work one release, hidden, with a warning)."""


def _options(name: str, capsys) -> set[str]:
    """Return the option strings ``batlab NAME --help`` lists."""
    with pytest.raises(SystemExit):
        build_parser([name]).parse_args([name, "--help"])
    text = capsys.readouterr().out
    return set(re.findall(r"(?<![\w-])(--?[A-Za-z][\w-]*)", text.split("options:")[1]))


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_speaks_the_same_options(name, capsys):
    options = _options(name, capsys)
    assert ({"-o", "--out"} <= options) == (name in WRITES), name
    assert ("--plots" in options) == (name in PLOTS), name
    assert not options & set(OLD), (name, options & set(OLD))
    if "--points" in options:  # point numbers only: a count is --n-points, inches --points-in
        assert name == "acquire"
    if name in {"model"}:
        assert "--n-points" in options
    if name in {"simulate", "acquire", "rig"}:
        assert "--points-in" in options


@pytest.mark.parametrize(("argv", "old", "new", "dest", "value"), [
    (["diagnose", "--profile", "p", "--meta", "m", "--frf", "f", "--plot", "D"], "--plot",
     "--plots", "plots", "D"),
    (["paper", "--plot"], "--plot", "--plots", "plots", "paper_figures"),
    (["fit", "t.uff", "--plot", "D"], "--plot", "--plots", "plots", "D"),
    (["export", "--output", "h.csv"], "--output", "-o", "out", "h.csv"),
    (["acquire", "--replay", "r.bin", "--output", "t.uff"], "--output", "--out", "out", "t.uff"),
    (["inspect", "r.uff", "--serial", "S", "--report", "D"], "--report", "-o", "out", "D"),
    (["model", "--points", "12"], "--points", "--n-points", "n_points", 12),
    (["simulate", "--points", "1,3"], "--points", "--points-in", "points_in", "1,3"),
])
def test_an_old_spelling_warns_and_still_works(argv, old, new, dest, value, capsys):
    args = build_parser([argv[0]]).parse_args(argv)
    assert getattr(args, dest) == value
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{old} is deprecated" in err[0] and "next release" in err[0]
    args = build_parser([argv[0]]).parse_args([new if a == old else a for a in argv])
    assert getattr(args, dest) == value and capsys.readouterr().err == ""


def test_old_spellings_run_a_command(tmp_path, capsys):
    out = tmp_path / "t.uff"
    assert main(["simulate", "--points", "1,5,9,13,17,21,25,29,33", "--df", "4", "--seed", "1",
                 "--profile", "data_samples/smooth_bat/profile.csv", "--out", str(out),
                 "--json"]) == 0
    captured = capsys.readouterr()
    assert "--points is deprecated" in captured.err
    assert json.loads(captured.out)["points_in"][-1] == 33
    folder = tmp_path / "case"
    assert main(["simulate", "--case", str(folder), "--nuisances", "none", "--seed", "2"]) == 0
    assert "--case DIR is deprecated" in capsys.readouterr().err
    assert (folder / "baseline.uff").is_file()
    assert main(["export", "--db", str(tmp_path / "none.sqlite")]) == 2
    assert "-o/--out FILE.csv is required" in capsys.readouterr().err


def test_fit_names_its_mass_bound_a_lower_bound(capsys):
    assert main(["fit", "data_samples/smooth_bat/baseline.uff", "--json"]) == 0
    rigid = json.loads(capsys.readouterr().out)["rigid_body"]
    weight_kg = json.loads(open("data_samples/smooth_bat/meta.json").read())["weight_lb"] \
        * 0.45359237
    assert 0.3 * weight_kg < rigid["mass_lower_bound_kg"] <= weight_kg  # M >= 1/a(x_d)
    assert rigid["mass_upper_bound_kg"] == rigid["mass_lower_bound_kg"]  # deprecated name
