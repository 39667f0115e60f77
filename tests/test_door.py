"""The door (#41): every unusable input refused in one line, before any work.

Each malformed input of tests/door_cases.py (meta.json, profile.csv, FRF files, retest.json,
options; each with every command that reads it), and hypothesis-drawn variants of them, must
exit 2 with exactly one stderr line that is not a progress line, naming the file (or option)
and the key, with no warning, no new file, and the registry byte-identical to before. The
harmless changes (a UTF-8 byte-order mark, CRLF line ends, an unknown key or column) still
work, the unknown names said once. The CLI runs in-process (``batlab.cli.main``).
"""

from __future__ import annotations

import datetime as dt
import hashlib
import io
import json
import re
import warnings
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from batlab.cli import main
from tests.door_cases import (
    SAMPLE,
    SERIAL,
    Folder,
    baseline_test,
    harmless_cases,
    malformed_cases,
    with_frf,
)

PROGRESS = re.compile(r"^batlab [\w-]+ \[\s*[\d.]+ s\]: ")
SETTINGS = settings(max_examples=15, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow])


def run(argv) -> tuple[int, str, str, list]:
    """(exit code, stdout, stderr, warnings that escaped) of ``batlab ARGV`` in-process."""
    out, err = io.StringIO(), io.StringIO()
    with warnings.catch_warnings(record=True) as caught, redirect_stdout(out), \
            redirect_stderr(err):
        warnings.simplefilter("always")
        code = main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue(), list(caught)


def snapshot(root: Path, db: Path) -> tuple[frozenset, dict]:
    """Every path under ``root``, and the SHA-256 of each file beside the registry."""
    paths = frozenset(str(p) for p in root.rglob("*"))
    registry = {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
                for p in sorted(db.parent.iterdir()) if p.is_file()}
    return paths, registry


def refusal_problem(root: Path, db: Path, argv, names) -> str:
    """Run a command that must be refused at the door: '' when it is, else what is wrong."""
    before = snapshot(root, db)
    code, out, err, caught = run(argv)
    lines = [ln for ln in err.splitlines() if ln.strip() and not PROGRESS.match(ln)]
    why = []
    if code != 2:
        why.append(f"exit {code}")
    if len(lines) != 1:
        why.append(f"{len(lines)} non-progress lines {lines[:3]}")
    elif missing := [n for n in names if n not in lines[0]]:
        why.append(f"{lines[0]!r} does not name {missing}")
    if caught or "Warning" in err:
        why.append(f"warnings {[str(w.message) for w in caught][:2]}")
    if out:
        why.append("stdout not empty")
    if "fitting modes" in err:
        why.append("fitted before refusing")
    after = snapshot(root, db)
    if after[0] != before[0]:
        why.append(f"files made or removed: {sorted(after[0] ^ before[0])[:2]}")
    if after[1] != before[1]:
        why.append("the registry changed")
    return "; ".join(why)


@pytest.fixture(scope="module")
def lab(tmp_path_factory) -> tuple[Path, Path]:
    """A folder with a registry holding the sample bat (real numerics): (root, registry)."""
    root = tmp_path_factory.mktemp("door")
    db = root / "registry" / "lab.sqlite"
    db.parent.mkdir()
    code, _, err, _ = run(["register", "--profile", SAMPLE / "profile.csv", "--meta",
                           SAMPLE / "meta.json", "--baseline", SAMPLE / "baseline.uff",
                           "--db", db])
    assert code == 0, err
    return root, db


def test_every_malformed_input_is_refused_at_the_door(lab):
    root, db = lab
    cases = malformed_cases(root / "cases", db)
    assert len(cases) > 200
    wrong = [f"{c.name}: {why}" for c in cases
             if (why := refusal_problem(root, db, c.argv, c.names))]
    assert not wrong, f"{len(wrong)} of {len(cases)}:\n" + "\n".join(wrong)


def test_a_refused_register_makes_no_registry(lab):
    """With no registry yet, a refused registration leaves none (nor its folder)."""
    root, db = lab
    folder = Folder(root, "no_registry")
    folder.json("meta.json", {**json.loads((SAMPLE / "meta.json").read_text()),
                              "serial": ""})
    new_db = root / "new" / "lab.sqlite"
    argv = ["register", "--profile", SAMPLE / "profile.csv", "--meta", folder / "meta.json",
            "--baseline", SAMPLE / "baseline.uff", "--db", new_db]
    assert refusal_problem(root, db, argv, ("meta.json", "serial")) == ""
    assert not new_db.parent.exists()


def _register_argv(folder: Folder, db: Path) -> list:
    return ["register", "--profile", folder / "profile.csv", "--meta", folder / "meta.json",
            "--baseline", folder / "baseline.uff", "--db", db]


def _meta(**changes) -> dict:
    return {**json.loads((SAMPLE / "meta.json").read_text()), **changes}


BAD_SERIAL = st.one_of(
    st.text(min_size=65, max_size=300),
    st.text(min_size=1, max_size=20).filter(lambda s: any(not " " <= c <= "~" for c in s)),
    st.tuples(st.text("ABC-0123", max_size=6), st.sampled_from("/\\"),
              st.text("ABC-0123", max_size=6)).map("".join),
    st.sampled_from(["", " ", ".", "..", " HX-1", "HX-1 "]),
)


@SETTINGS
@given(serial=BAD_SERIAL, where=st.sampled_from(["meta.json", "--serial"]))
def test_any_unusable_serial_is_refused(lab, serial, where):
    root, db = lab
    folder = Folder(root, "drawn_serial")
    if where == "meta.json":
        folder.json("meta.json", _meta(serial=serial))
        argv, names = _register_argv(folder, db), ("meta.json", "serial")
    else:
        argv = ["inspect", f"--serial={serial}", SAMPLE / "retest_corked.uff", "--db", db]
        names = ("--serial",)  # (--serial=VALUE: a value may begin with "-")
    assert refusal_problem(root, db, argv, names) == ""


TEXT_NUMBER = st.floats(0.1, 1e7).map(lambda v: f"{v:g}")


@SETTINGS
@given(key=st.sampled_from(["weight_lb", "nominal_E_psi", "nominal_weight_density_lbf_in3",
                            "accelerometer_mass_g", "temperature_c"]),
       value=st.one_of(TEXT_NUMBER, st.booleans(), st.lists(st.floats(0, 3), max_size=2)))
def test_a_number_of_another_json_type_is_refused(lab, key, value):
    root, db = lab
    folder = Folder(root, "drawn_number")
    folder.json("meta.json", _meta(**{key: value}))
    assert refusal_problem(root, db, _register_argv(folder, db), ("meta.json", key)) == ""


@SETTINGS
@given(drop=st.integers(0, 16), shift_in=st.floats(-3.0, 3.0).filter(lambda s: abs(s) > 0.3),
       how=st.sampled_from(["drop", "shift", "add", "empty"]))
def test_points_in_that_are_not_the_tests_are_refused(lab, drop, shift_in, how):
    root, db = lab
    points = list(_meta()["points_in"])
    if how == "drop":
        points.pop(drop)
    elif how == "shift":
        points[drop] = min(max(points[drop] + shift_in, 0.0), 33.5)
        if min(abs(points[drop] - p) for k, p in enumerate(points) if k != drop) < 0.3:
            return  # moved onto another point: a list of 16 distinct ones is the drop case
    elif how == "add":
        points.append(0.5 + abs(shift_in))
    else:
        points = []
    folder = Folder(root, "drawn_points")
    folder.json("meta.json", _meta(points_in=points))
    assert refusal_problem(root, db, _register_argv(folder, db), ("meta.json",
                                                                  "points_in")) == ""


@SETTINGS
@given(days=st.one_of(st.integers(2, 40_000), st.integers(-40_000, -1)),
       form=st.sampled_from(["iso", "integer", "slashes"]))
def test_a_retest_date_out_of_range_or_form_is_refused(lab, days, form):
    root, db = lab
    today = dt.date.today()
    day = today + dt.timedelta(days=days) if days > 0 else \
        dt.date(1990, 1, 1) + dt.timedelta(days=days)
    if day.year < 1 or day.year > 9999:
        return
    value = {"iso": day.isoformat(), "integer": int(day.strftime("%Y%m%d")),
             "slashes": day.strftime("%d/%m/%Y")}[form]
    folder = Folder(root, "drawn_date")
    path = folder.json("retest.json", {"tested_on": value})
    argv = ["inspect", "--serial", SERIAL, SAMPLE / "retest_corked.uff", "--db", db,
            "--retest-meta", path]
    assert refusal_problem(root, db, argv, ("retest.json", "tested_on")) == ""


@SETTINGS
@given(scale_log10=st.one_of(st.floats(16, 300), st.floats(-300, -18)),
       zero=st.one_of(st.none(), st.integers(0, 16)))
def test_an_frf_test_at_an_impossible_scale_or_with_a_dead_frf_is_refused(lab, scale_log10,
                                                                          zero):
    root, db = lab
    t = baseline_test()
    h = t.frf * 10.0 ** scale_log10 if zero is None else t.frf.copy()
    if zero is not None:
        h[:, 0, zero] = 0.0
    folder = Folder(root, "drawn_frf")
    folder.frf("baseline.uff", with_frf(t, h))
    for argv in (_register_argv(folder, db), ["fit", folder / "baseline.uff", "--json"]):
        assert refusal_problem(root, db, argv, ("baseline.uff",)) == ""


@SETTINGS
@given(extra=st.lists(st.sampled_from(["operator", "note", "angle", "x_mm"]), min_size=1,
                      max_size=3, unique=True),
       swap=st.booleans())
def test_a_profile_header_swapped_is_refused_an_extra_column_noted(lab, extra, swap):
    root, db = lab
    rows = np.loadtxt(SAMPLE / "profile.csv", delimiter=",", skiprows=1)
    head = ["diameter_in", "x_in"] if swap else ["x_in", "diameter_in"]
    folder = Folder(root, "drawn_profile")
    folder.text("profile.csv", ",".join([*head, *extra]) + "\n" + "".join(
        f"{x:g},{d:g}" + ",7" * len(extra) + "\n" for x, d in rows))
    argv = ["diagnose", "--profile", folder / "profile.csv", "--meta", SAMPLE / "meta.json",
            "--frf", SAMPLE / "one_missing.uff"]  # no such file: refused after the profile
    if swap:
        assert refusal_problem(root, db, argv, ("profile.csv", "swapped")) == ""
        return
    code, _, err, _ = run(argv)
    assert code == 2
    notes = [ln for ln in err.splitlines() if "not used (ignored)" in ln]
    assert len(notes) == 1 and all(repr(e) in notes[0] for e in extra)


@pytest.mark.parametrize("change", ["bom", "crlf", "bom_crlf", "unknown"])
def test_harmless_changes_still_work(tmp_path, monkeypatch, change):
    """A byte-order mark, CRLF line ends and unknown keys or columns are read as the plain
    files are (stand-in numerics: the door is what is tested); unknown names said once."""
    from tests.inspect_standins import use_standins

    use_standins(monkeypatch)
    folder = dict(harmless_cases(tmp_path / "cases"))[change]
    db = tmp_path / "lab.sqlite"
    code, _, err, caught = run(_register_argv(folder, db))
    assert code == 0, err
    code, out, err, _ = run(["inspect", "--serial", SERIAL, SAMPLE / "retest_corked.uff",
                             "--db", db, "--retest-meta", folder / "retest.json", "--json"])
    assert code == 0, err
    assert json.loads(out)["serial"] == SERIAL and not caught
    plain = tmp_path / "plain.sqlite"
    assert run(_register_argv(Folder(tmp_path, "plain"), plain))[0] == 0
    from batlab.registry import get_bat, open_registry

    with open_registry(db) as a, open_registry(plain) as b:
        mine, theirs = get_bat(a, SERIAL), get_bat(b, SERIAL)
    assert mine.profile_x_m == theirs.profile_x_m
    assert mine.profile_diameter_m == theirs.profile_diameter_m
    assert mine.meta["points_in"] == theirs.meta["points_in"]
    noted = [ln for ln in err.splitlines() if "not used (ignored)" in ln]
    assert len(noted) == (1 if change == "unknown" else 0)  # retest.json's 'technician'


def test_numpy_warnings_never_reach_the_user_unless_asked(monkeypatch):
    """A warning raised during a command is not shown (the command's result or its one-line
    error is the answer); ``python -W`` (sys.warnoptions) shows it to a developer."""
    import sys

    import batlab.commands.model as model

    def noisy(args):
        np.log(np.zeros(2))  # numpy: divide by zero (RuntimeWarning)
        warnings.warn("scipy would say this", RuntimeWarning, stacklevel=1)
        return 0

    monkeypatch.setattr(model, "run", noisy)
    code, _, err, caught = run(["model"])
    assert code == 0 and not caught and "Warning" not in err
    monkeypatch.setattr(sys, "warnoptions", ["default"])
    code, _, _, caught = run(["model"])
    assert code == 0 and len(caught) == 2


def test_a_fit_failing_on_its_numbers_is_one_line_naming_the_file(monkeypatch, tmp_path):
    """What no input check foresaw: the fit's own numerical failure is one line naming the
    file, for `fit` and for a bat's baseline."""
    from ema import modal_fit
    from updating.correlate import fitted

    def singular(*args, **kwargs):
        raise np.linalg.LinAlgError("Singular matrix")

    monkeypatch.setattr(modal_fit, "fit_test", singular)
    monkeypatch.setattr(fitted, "fit_test", singular)
    code, _, err, caught = run(["fit", SAMPLE / "baseline.uff", "--json"])
    lines = [ln for ln in err.splitlines() if not PROGRESS.match(ln)]
    assert code == 2 and not caught
    assert lines[-1].endswith("baseline.uff: the fit failed on its numbers (Singular matrix): "
                              "check the FRFs' units and scale")
    db = tmp_path / "lab.sqlite"
    code, _, err, _ = run(_register_argv(Folder(tmp_path, "bat"), db))
    lines = [ln for ln in err.splitlines() if ln.strip() and not PROGRESS.match(ln)]
    assert code == 2 and len(lines) == 1 and "baseline.uff: the fit failed" in lines[0]
    assert not db.exists()
