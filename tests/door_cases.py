"""The malformed inputs of issue #41, made from one valid bat's files (data_samples/smooth_bat).

``malformed_cases(root, db)`` writes every case's files under ``root/<case>/`` and returns
the cases: a command line, and the words its one-line refusal must hold (the file or option,
and the key). ``db`` is an existing registry with the sample bat registered (``SERIAL``);
commands that take a registry get it, so a refusal can be checked to leave it as it was.

Each malformed file is tried with every command that reads it (``register``, both forms of
``inspect``, ``diagnose``, ``fit``). ``harmless_cases`` are the same files with a change that
must still work (a UTF-8 byte-order mark, CRLF line ends, an unknown key or column).

Used by tests/test_door.py (every case, in-process) and benchmarks/bench_door.py (every
case as a user runs it, a subprocess, timed).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ema.io.frf_data import FrfTest
from ema.io.frf_io import read_test, write_test

SAMPLE = Path(__file__).resolve().parents[1] / "data_samples" / "smooth_bat"
SERIAL = "HX-2001"
DROP = object()
"""A meta.json or retest.json value that removes the key."""


@dataclass(frozen=True)
class Case:
    """One malformed input and how its refusal must read.

    Attributes
    ----------
    name : str
        What is wrong, and the command (``weight_lb_missing/register``).
    argv : tuple of str
        The ``batlab`` command line.
    names : tuple of str
        Words the one-line refusal must all hold (the file or option, and the key).
    """

    name: str
    argv: tuple[str, ...]
    names: tuple[str, ...]


def _meta_dict(**changes) -> dict:
    meta = json.loads((SAMPLE / "meta.json").read_text())
    for key, value in changes.items():
        if value is DROP:
            meta.pop(key, None)
        else:
            meta[key] = value
    return meta


def baseline_test() -> FrfTest:
    """The sample bat's baseline test as read."""
    return read_test(SAMPLE / "baseline.uff")


def with_frf(test: FrfTest, frf: np.ndarray, keep: np.ndarray | None = None) -> FrfTest:
    """``test`` with its FRFs replaced (and only the reference columns ``keep``)."""
    refs = test.reference_nodes if keep is None else test.reference_nodes[keep]
    h = frf if keep is None else frf[:, :, keep]
    nodes = {int(n): test.node_x_m[int(n)] for n in (*refs, *test.response_nodes)}
    return FrfTest(test.freq_hz, h, test.response_nodes, refs, nodes, test.quantity)


class Folder:
    """A case's folder: the sample bat's four files, those the case changes written there."""

    def __init__(self, root: Path, name: str):
        self.path = root / name.replace("/", "_").replace(" ", "_")
        self.path.mkdir(parents=True, exist_ok=True)

    def __truediv__(self, name: str) -> Path:
        """The case's file ``name``: its own if written, else the sample's."""
        own = self.path / name
        return own if own.exists() or own.is_symlink() or not (SAMPLE / name).exists() \
            else SAMPLE / name

    def _fresh(self, name: str) -> Path:
        path = self.path / name
        if path.is_dir():
            path.rmdir()
        path.unlink(missing_ok=True)
        return path

    def text(self, name: str, text: str | bytes) -> Path:
        path = self._fresh(name)
        (path.write_bytes if isinstance(text, bytes) else path.write_text)(text)
        return path

    def json(self, name: str, obj) -> Path:
        return self.text(name, obj if isinstance(obj, str) else json.dumps(obj))

    def directory(self, name: str) -> Path:
        path = self._fresh(name)
        path.mkdir()
        return path

    def missing(self, name: str) -> Path:
        """The name of a file that is not there (the sample's is not used)."""
        path = self._fresh(name)
        path.symlink_to(self.path / f"{name}.nowhere")  # a dangling link: no such file
        return path

    def frf(self, name: str, test: FrfTest) -> Path:
        path = self._fresh(name)
        write_test(path, test)
        return path


def _files(f: Folder) -> dict[str, str]:
    return {k: str(f / n) for k, n in (("p", "profile.csv"), ("m", "meta.json"),
                                       ("b", "baseline.uff"), ("r", "retest_corked.uff"))}


def _register(f: Folder, db: Path) -> tuple[str, ...]:
    x = _files(f)
    return ("register", "--profile", x["p"], "--meta", x["m"], "--baseline", x["b"],
            "--db", str(db))


def _stateless(f: Folder, retest_meta: Path | None = None) -> tuple[str, ...]:
    x = _files(f)
    extra = ("--retest-meta", str(retest_meta)) if retest_meta else ()
    return ("inspect", "--profile", x["p"], "--meta", x["m"], "--baseline", x["b"],
            "--retest", x["r"], "--json", *extra)


def _diagnose(f: Folder) -> tuple[str, ...]:
    x = _files(f)
    return ("diagnose", "--profile", x["p"], "--meta", x["m"], "--frf", x["b"], "--json")


def _serial(f: Folder, db: Path, retest_meta: Path | None = None) -> tuple[str, ...]:
    extra = ("--retest-meta", str(retest_meta)) if retest_meta else ()
    return ("inspect", "--serial", SERIAL, str(f / "retest_corked.uff"), "--db", str(db),
            "--json", *extra)


def _fit(f: Folder) -> tuple[str, ...]:
    return ("fit", str(f / "baseline.uff"), "--json")


BAT_COMMANDS: dict[str, Callable[[Folder, Path], tuple[str, ...]]] = {
    "register": _register,
    "inspect": lambda f, db: _stateless(f),
    "diagnose": lambda f, db: _diagnose(f),
}
"""The commands that read a bat's profile.csv, meta.json and baseline."""

META_CASES: dict[str, tuple[dict, tuple[str, ...]]] = {
    # case: (meta.json's changes, words of the refusal besides "meta.json")
    "weight_lb_missing": ({"weight_lb": DROP}, ("weight_lb",)),
    "weight_lb_null": ({"weight_lb": None}, ("weight_lb",)),
    "weight_lb_text": ({"weight_lb": "1.9259"}, ("weight_lb",)),
    "weight_lb_zero": ({"weight_lb": 0}, ("weight_lb",)),
    "weight_lb_bool": ({"weight_lb": True}, ("weight_lb",)),
    "weight_lb_list": ({"weight_lb": [1.78]}, ("weight_lb",)),
    "nominal_E_text": ({"nominal_E_psi": "1740000"}, ("nominal_E_psi",)),
    "nominal_E_missing": ({"nominal_E_psi": DROP}, ("nominal_E_psi",)),
    "density_text": ({"nominal_weight_density_lbf_in3": "0.0217"},
                     ("nominal_weight_density_lbf_in3",)),
    "species_number": ({"species": 42}, ("species",)),
    "species_null": ({"species": None}, ("species",)),
    "species_missing": ({"species": DROP}, ("species",)),
    "species_empty": ({"species": " "}, ("species",)),
    "serial_null": ({"serial": None}, ("serial",)),
    "serial_missing": ({"serial": DROP}, ("serial",)),
    "serial_empty": ({"serial": ""}, ("serial",)),
    "serial_number": ({"serial": 2001}, ("serial",)),
    "serial_newline": ({"serial": "HX-\n2001"}, ("serial",)),
    "serial_nul": ({"serial": "HX-2001\x00"}, ("serial",)),
    "serial_10000": ({"serial": "H" * 10_000}, ("serial",)),
    "serial_dotdot": ({"serial": "../../etc/x"}, ("serial",)),
    "serial_slash": ({"serial": "HX/1007"}, ("serial",)),
    "serial_backslash": ({"serial": "HX\\1007"}, ("serial",)),
    "serial_non_ascii": ({"serial": "HX-2001\u00e9"}, ("serial",)),
    "points_empty": ({"points_in": []}, ("points_in",)),
    "points_missing": ({"points_in": DROP}, ("points_in",)),
    "points_one_short": ({"points_in": [float(x) for x in range(1, 33, 2)]}, ("points_in",)),
    "points_one_more": ({"points_in": [float(x) for x in range(1, 35, 2)] + [33.5]},
                        ("points_in",)),
    "points_moved": ({"points_in": [1.0, 3.0, 5.0, 7.0, 9.0, 11.0, 13.0, 15.0, 17.0, 19.0, 21.0,
                                    23.0, 25.0, 27.0, 29.0, 30.0, 33.0]}, ("points_in",)),
    "points_text": ({"points_in": "1,3,5"}, ("points_in",)),
    "points_text_item": ({"points_in": [1.0, "3.0", *map(float, range(5, 35, 2))]},
                         ("points_in",)),
    "points_nested": ({"points_in": [[1.0, 3.0]]}, ("points_in",)),
    "points_number": ({"points_in": 5.0}, ("points_in",)),
    "accelerometer_text": ({"accelerometer_mass_g": "4"}, ("accelerometer_mass_g",)),
    "accelerometer_negative": ({"accelerometer_mass_g": -3.0}, ("accelerometer_mass_g",)),
    "temperature_text": ({"temperature_c": "hot"}, ("temperature_c",)),
    "tested_on_future": ({"tested_on": "2099-01-01"}, ("tested_on",)),
    "moisture_off_the_bat": ({"moisture": [{"x_in": 40.0, "mc_pct": 9.0}]},
                             ("moisture", "x_in", "off the bat")),
    "humidity_text": ({"humidity_pct": "45"}, ("humidity_pct",)),
}
"""meta.json's malformed values."""

META_TEXT_CASES: dict[str, tuple[str | bytes, tuple[str, ...]]] = {
    "meta_not_json": ('{"serial": "HX-2001",', ()),
    "meta_empty": ("", ()),
    "meta_a_list": ("[1, 2, 3]", ()),
    "meta_binary": (b"\xff\xfe\x00\x01garbage", ()),
    "meta_points_nan": (json.dumps(_meta_dict()).replace('"points_in": [1.0',
                                                         '"points_in": [NaN'), ("points_in",)),
    "meta_weight_infinity": (json.dumps(_meta_dict(weight_lb="INF")).replace('"INF"',
                                                                             "Infinity"),
                             ("weight_lb",)),
}
"""meta.json's malformed text."""

PROFILE_HEAD = "x_in,diameter_in\n"


def _profile_rows() -> np.ndarray:
    return np.loadtxt(SAMPLE / "profile.csv", delimiter=",", skiprows=1)


def _rows_text(rows: np.ndarray) -> str:
    return "".join(f"{x:g},{d:g}\n" for x, d in rows)


def profile_texts() -> dict[str, tuple[str | bytes, tuple[str, ...]]]:
    """profile.csv's malformed texts: (text, words of the refusal besides "profile.csv")."""
    rows = _profile_rows()
    body = _rows_text(rows)
    dec = rows.copy()
    dec[10, 0] = dec[9, 0] - 1.0
    nan = body.replace(f"{rows[5, 1]:g}", "nan", 1)
    return {
        "profile_swapped_header": ("diameter_in,x_in\n" + body, ("x_in", "diameter_in")),
        "profile_no_diameter": ("x_in,d_in\n" + body, ("diameter_in",)),
        "profile_empty": ("", ()),
        "profile_header_only": (PROFILE_HEAD, ()),
        "profile_one_row": (PROFILE_HEAD + "0,1.2\n", ()),
        "profile_text_cell": (PROFILE_HEAD + body.replace(f"{rows[3, 1]:g}", "wide", 1),
                              ()),
        "profile_nan_cell": (PROFILE_HEAD + nan, ("diameter_in",)),
        "profile_x_decreasing": (PROFILE_HEAD + _rows_text(dec), ("x",)),
        "profile_zero_diameter": (PROFILE_HEAD + _rows_text(rows * [1, 0]), ("diameter",)),
        "profile_millimetres": (PROFILE_HEAD + _rows_text(rows * 25.4), ("millimetres",)),
        "profile_binary": (b"\x00\x01\xff" * 40, ()),
        "profile_short_row": (PROFILE_HEAD + body + "35\n", ()),
    }


def frf_variants() -> dict[str, tuple[FrfTest, tuple[str, ...]]]:
    """The baseline test's malformed variants: (test, words besides the file name)."""
    t = baseline_test()
    i, j = t.driving_point
    zero_drive = t.frf.copy()
    zero_drive[:, i, j] = 0.0
    one_zero = t.frf.copy()
    one_zero[:, 0, 3] = 0.0
    knob_only = np.flatnonzero(t.x_m(t.reference_nodes) < 0.3)
    return {
        "frf_driving_point_zero": (with_frf(t, zero_drive), ("node",)),
        "frf_all_zero": (with_frf(t, 0 * t.frf), ()),
        "frf_one_zero": (with_frf(t, one_zero), ("node",)),
        "frf_scaled_1e300": (with_frf(t, 1e300 * t.frf), ()),
        "frf_scaled_1e-300": (with_frf(t, 1e-300 * t.frf), ()),
        "frf_driving_point_only": (with_frf(t, t.frf, np.array([j])), ()),
        "frf_no_barrel": (with_frf(t, t.frf, np.append(knob_only, j)), ()),
    }


FILE_FAULTS = {
    "directory": lambda f, name: f.directory(name),
    "missing": lambda f, name: f.missing(name),
    "empty": lambda f, name: f.text(name, ""),
}
"""What can be wrong with any input file as a file."""

RETEST_JSON_CASES: dict[str, tuple[object, tuple[str, ...]]] = {
    "tested_on_2099": ({"tested_on": "2099-01-01"}, ("tested_on",)),
    "tested_on_1900": ({"tested_on": "1900-01-01"}, ("tested_on",)),
    "tested_on_integer": ({"tested_on": 20260502}, ("tested_on",)),
    "tested_on_month_13": ({"tested_on": "2026-13-01"}, ("tested_on",)),
    "tested_on_words": ({"tested_on": "yesterday"}, ("tested_on",)),
    "retest_weight_text": ({"weight_lb": "1.78"}, ("weight_lb",)),
    "retest_weight_grams": ({"weight_lb": 809.3}, ("weight_lb",)),
    "retest_temperature_500": ({"temperature_c": 500}, ("temperature_c",)),
    "retest_accelerometer_negative": ({"accelerometer_mass_g": -1}, ("accelerometer_mass_g",)),
    "moisture_mc_45": ({"moisture": [{"x_in": 31.0, "mc_pct": 45.0}]}, ("moisture", "mc_pct")),
    "moisture_off_the_bat": ({"moisture": [{"x_in": 40.0, "mc_pct": 9.0}]},
                             ("moisture", "x_in", "off the bat")),
    "moisture_not_records": ({"moisture": [9.0, 9.2]}, ("moisture",)),
    "humidity_120": ({"humidity_pct": 120}, ("humidity_pct",)),
    "conditioned_negative": ({"conditioned_h": -1}, ("conditioned_h",)),
    "retest_json_list": ("[]", ()),
    "retest_json_broken": ('{"weight_lb": ', ()),
}
"""retest.json's malformed contents (a dict, or the file's text)."""


def _bat_file_cases(root: Path, db: Path) -> list[Case]:
    cases = []
    for name, (changes, words) in META_CASES.items():
        for cmd, argv in BAT_COMMANDS.items():
            f = Folder(root, f"{name}/{cmd}")
            f.json("meta.json", _meta_dict(**changes))
            cases.append(Case(f"{name}/{cmd}", argv(f, db), ("meta.json", *words)))
    for name, (text, words) in META_TEXT_CASES.items():
        f = Folder(root, name)
        f.text("meta.json", text)
        cases.append(Case(f"{name}/register", _register(f, db), ("meta.json", *words)))
    for name, (text, words) in profile_texts().items():
        for cmd, argv in BAT_COMMANDS.items():
            f = Folder(root, f"{name}/{cmd}")
            f.text("profile.csv", text)
            cases.append(Case(f"{name}/{cmd}", argv(f, db), ("profile.csv", *words)))
    for fault, make in FILE_FAULTS.items():
        for file in ("profile.csv", "meta.json", "baseline.uff"):
            f = Folder(root, f"{file}_{fault}")
            make(f, file)
            cases.append(Case(f"{file}_{fault}/register", _register(f, db), (file,)))
    return cases


def _frf_cases(root: Path, db: Path) -> list[Case]:
    cases = []
    for name, (test, words) in frf_variants().items():
        f = Folder(root, name)
        f.frf("baseline.uff", test)
        commands = dict(BAT_COMMANDS, fit=lambda f, db: _fit(f))
        if name in ("frf_driving_point_only", "frf_no_barrel"):  # a baseline's, not a fit's
            commands.pop("fit")
            commands.pop("diagnose") if name == "frf_no_barrel" else None
        for cmd, argv in commands.items():
            cases.append(Case(f"{name}/{cmd}", argv(f, db), ("baseline.uff", *words)))
        g = Folder(root, f"{name}_retest")
        g.frf("retest_corked.uff", test)
        if name not in ("frf_no_barrel",):
            cases.append(Case(f"{name}/inspect --serial", _serial(g, db),
                              ("retest_corked.uff", *words)))
    for fault, make in FILE_FAULTS.items():
        f = Folder(root, f"retest_{fault}")
        make(f, "retest_corked.uff")
        cases.append(Case(f"retest_{fault}/inspect --serial", _serial(f, db),
                          ("retest_corked.uff",)))
        cases.append(Case(f"retest_{fault}/inspect", _stateless(f), ("retest_corked.uff",)))
        g = Folder(root, f"fit_{fault}")
        make(g, "baseline.uff")
        cases.append(Case(f"fit_{fault}/fit", _fit(g), ("baseline.uff",)))
    t = baseline_test()
    i, j = t.driving_point
    x_in = t.x_m(t.reference_nodes) / 0.0254
    for name, keep, words in (("driving_point_only", np.array([j]), ("at least",)),
                              ("no_barrel", np.append(np.flatnonzero(x_in < 12), j),
                               ("barrel",))):
        f = Folder(root, f"baseline_{name}_listed")  # meta.json lists the test's points
        f.frf("baseline.uff", with_frf(t, t.frf, keep))
        f.json("meta.json", _meta_dict(points_in=[round(float(x), 3) for x in x_in[keep]]))
        for cmd in ("register", "inspect"):
            cases.append(Case(f"baseline_{name}_listed/{cmd}", BAT_COMMANDS[cmd](f, db),
                              ("baseline.uff", *words)))
    f = Folder(root, "retest_few_points")
    t = baseline_test()
    f.frf("retest_corked.uff", with_frf(t, t.frf, np.arange(8, t.reference_nodes.size)))
    cases.append(Case("retest_few_points/inspect --serial", _serial(f, db),
                      ("retest_corked.uff",)))
    return cases


def _retest_json_cases(root: Path, db: Path) -> list[Case]:
    cases = []
    for name, (content, words) in RETEST_JSON_CASES.items():
        f = Folder(root, name)
        path = f.json("retest.json", content)
        cases.append(Case(f"{name}/inspect --serial", _serial(f, db, path),
                          ("retest.json", *words)))
        cases.append(Case(f"{name}/inspect", _stateless(f, path), ("retest.json", *words)))
    for fault in ("directory", "missing"):
        f = Folder(root, f"retest_json_{fault}")
        path = FILE_FAULTS[fault](f, "retest.json")
        cases.append(Case(f"retest_json_{fault}/inspect --serial", _serial(f, db, path),
                          ("retest.json",)))
    return cases


def _option_cases(root: Path, db: Path) -> list[Case]:
    f = Folder(root, "options")
    x = _files(f)
    plain = f.text("plain_file", "not a directory\n")
    reg = ("register", "--profile", x["p"], "--meta", x["m"], "--baseline", x["b"])
    stateless = _stateless(f)
    return [
        Case("serial_option_empty/register", (*reg, "--serial", "", "--db", str(db)),
             ("--serial",)),
        Case("serial_option_dotdot/register", (*reg, "--serial", "../x", "--db", str(db)),
             ("--serial",)),
        Case("serial_option_other/register", (*reg, "--serial", "HX-9", "--db", str(db)),
             ("--serial", "meta.json")),
        Case("serial_option_newline/inspect", ("inspect", "--serial", "HX\n1", x["r"],
                                               "--db", str(db)), ("--serial",)),
        Case("serial_option_slash/history", ("history", "a/b", "--db", str(db)),
             ("serial",)),
        Case("db_mysql/register", (*reg, "--db", "mysql://u@host/lab"), ("--db", "mysql://")),
        Case("db_mysql/bats", ("bats", "--db", "mysql://u@host/lab"), ("--db", "mysql://")),
        Case("db_directory/register", (*reg, "--db", str(f.directory("registry_dir"))),
             ("registry_dir",)),
        Case("db_under_a_file/register", (*reg, "--db", str(plain / "lab.sqlite")),
             ("plain_file",)),
        Case("db_missing/inspect --serial", ("inspect", "--serial", SERIAL, x["r"], "--db",
                                             str(f / "none.sqlite")), ("none.sqlite",)),
        Case("fit_out_no_dir/fit", ("fit", x["b"], "-o", str(f / "nodir" / "x" / "modes.uff")),
             ("nodir",)),
        Case("fit_out_is_dir/fit", ("fit", x["b"], "-o", str(f.directory("a_dir"))),
             ("a_dir",)),
        Case("fit_plots_on_file/fit", ("fit", x["b"], "--plots", str(plain)), ("plain_file",)),
        Case("fit_band_reversed/fit", ("fit", x["b"], "--band", "3200", "20"), ("--band",)),
        Case("fit_band_nan/fit", ("fit", x["b"], "--band", "nan", "3200"), ("--band",)),
        Case("fit_mass_negative/fit", ("fit", x["b"], "--mass-kg", "-1"), ("--mass-kg",)),
        Case("fit_min_snr_nan/fit", ("fit", x["b"], "--min-snr", "nan"), ("--min-snr",)),
        Case("fit_max_order_zero/fit", ("fit", x["b"], "--max-order", "0"), ("--max-order",)),
        Case("inspect_out_on_file/inspect", (*stateless, "-o", str(plain)), ("plain_file",)),
        Case("inspect_plots_under_file/inspect", (*stateless, "--plots", str(plain / "p")),
             ("plain_file",)),
        Case("inspect_false_alarm_nan/inspect", (*stateless, "--false-alarm", "nan"),
             ("--false-alarm",)),
        Case("diagnose_min_gain_negative/diagnose", (*_diagnose(f), "--min-gain", "-1"),
             ("--min-gain",)),
    ]


def malformed_cases(root: Path, db: Path) -> list[Case]:
    """Write every malformed case's files under ``root`` and return the cases.

    Parameters
    ----------
    root : Path
        A folder for the cases' files (one sub-folder each).
    db : Path
        An existing registry holding the sample bat as ``SERIAL``.

    Returns
    -------
    list of Case
        Each command line must exit 2 with one line holding ``Case.names``.
    """
    return [*_bat_file_cases(root, db), *_frf_cases(root, db), *_retest_json_cases(root, db),
            *_option_cases(root, db)]


def harmless_cases(root: Path) -> list[tuple[str, Folder]]:
    """The sample bat's files with harmless changes: BOM, CRLF, unknown keys and columns.

    Returns
    -------
    list of (str, Folder)
        The change, and the folder whose profile.csv, meta.json and retest.json must be
        accepted (``retest.json`` is written into each).
    """
    out = []
    meta = (SAMPLE / "meta.json").read_text()
    prof = (SAMPLE / "profile.csv").read_text()
    retest = json.dumps({"weight_lb": 1.78, "temperature_c": 21.0, "tested_on": "2026-05-02"})
    for name, change in (("bom", lambda s: "\ufeff" + s),
                         ("crlf", lambda s: s.replace("\n", "\r\n")),
                         ("bom_crlf", lambda s: "\ufeff" + s.replace("\n", "\r\n"))):
        f = Folder(root, f"harmless_{name}")
        f.text("meta.json", change(meta).encode())
        f.text("profile.csv", change(prof).encode())
        f.text("retest.json", change(retest).encode())
        out.append((name, f))
    f = Folder(root, "harmless_unknown")
    f.json("meta.json", {**json.loads(meta), "colour": "natural"})
    rows = _profile_rows()
    f.text("profile.csv", "x_in,diameter_in,operator\n"
           + "".join(f"{x:g},{d:g},JS\n" for x, d in rows))
    f.json("retest.json", {"weight_lb": 1.78, "technician": "JS"})
    out.append(("unknown", f))
    return out
