"""Hostile inputs, generated: a UFF file with any field replaced by junk, inf, nan or an
absurd number, and meta.json, profile CSV and retest.json with any value of any JSON type.
Each reader either returns finite data or raises one ValueError naming the file; nothing
else (no OverflowError, TypeError, IndexError, traceback) gets out."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ema.io.uff import read_uff, write_uff
from tests.frf_fixtures import bat_test
from updating.inspect.retest_meta import read_retest_meta
from updating.model.lab_input import read_meta
from updating.model.profile import read_profile_csv

HOSTILE = st.sampled_from(["inf", "-inf", "nan", "NaN", "1e300", "-1e300", "1e999", "-1", "0",
                           "abc", "", "9" * 40, "1.5", "-0", "0x10", "1D+400", "E"])
SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])


def _one_line_error(exc: ValueError, path: Path) -> None:
    text = str(exc)
    assert "\n" not in text and str(path) in text, text


@pytest.fixture(scope="module")
def uff_lines(tmp_path_factory) -> list[bytes]:
    path = tmp_path_factory.mktemp("uff") / "small.uff"
    write_uff(path, bat_test(n_points=3, n_lines=9), binary=False)
    return path.read_bytes().split(b"\n")


def _header_lines(lines: list[bytes]) -> list[int]:
    """Indices of every dataset's first 12 lines (its type, node records, 58's records 1-11),
    where one field decides how the rest is read."""
    out, start = [], None
    for k, line in enumerate(lines):
        if line.strip() == b"-1":
            start = None if start is not None else k
        elif start is not None and k - start <= 12:
            out.append(k)
    return out


@SETTINGS
@given(where=st.floats(0, 0.9999), token=st.integers(0, 8), junk=HOSTILE)
def test_uff_reader_with_a_field_replaced(uff_lines, tmp_path, where, token, junk):
    lines = list(uff_lines)
    headers = _header_lines(lines)
    k = headers[int(where * len(headers))]
    fields = lines[k].split()
    if fields:
        i = token % len(fields)
        width = max(len(fields[i]), len(junk))
        fields[i] = junk.encode().rjust(width)
        lines[k] = b" ".join(f.rjust(10) for f in fields)
    path = tmp_path / "fuzzed.uff"
    path.write_bytes(b"\n".join(lines))
    try:
        test = read_uff(path)
    except ValueError as exc:
        _one_line_error(exc, path)
        return
    assert all(math.isfinite(x) for x in test.node_x_m.values())
    assert np.all(np.isfinite(test.freq_hz))


@SETTINGS
@given(cut=st.floats(0, 1), flip=st.lists(st.tuples(st.floats(0, 0.9999),
                                                    st.integers(0, 255)), max_size=4))
def test_uff_reader_with_bytes_cut_or_changed(uff_lines, tmp_path, cut, flip):
    data = bytearray(b"\n".join(uff_lines)[:max(1, int(cut * sum(map(len, uff_lines))))])
    for where, byte in flip:
        data[int(where * len(data))] = byte
    path = tmp_path / "cut.uff"
    path.write_bytes(bytes(data))
    try:
        read_uff(path)
    except ValueError as exc:
        _one_line_error(exc, path)


JSON_VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-10**400, 10**400),
    st.floats(allow_nan=False, allow_infinity=False), st.text(max_size=8),
    st.sampled_from(["inf", "nan", "1e300", "-1e300", "2.1"]),
    st.lists(st.floats(allow_nan=False, allow_infinity=False), max_size=3))
META = {"serial": "F-1", "species": "maple", "nominal_E_psi": 1.7e6,
        "nominal_weight_density_lbf_in3": 0.0217, "weight_lb": 2.0, "points_in": [1.0, 5.0],
        "accelerometer_mass_g": 4.0}


def _write_json(path: Path, raw: dict, nonfinite: str | None) -> None:
    text = json.dumps(raw)
    if nonfinite:  # Python's json writes and reads these; a lab's file may hold them
        text = text.replace('"__NONFINITE__"', nonfinite)
    path.write_text(text)


@SETTINGS
@given(key=st.sampled_from(sorted(META)), value=JSON_VALUES,
       nonfinite=st.sampled_from([None, "Infinity", "-Infinity", "NaN", "1e999"]))
def test_meta_json_with_any_value(tmp_path, key, value, nonfinite):
    path = tmp_path / "meta.json"
    _write_json(path, {**META, key: "__NONFINITE__" if nonfinite else value}, nonfinite)
    try:
        meta = read_meta(path)
    except ValueError as exc:
        _one_line_error(exc, path)
        return
    m = meta.material
    assert 1e7 < m.E_pa < 1e12 and 1.0 < m.rho_kg_m3 < 3e4  # any wood, with room to spare
    assert meta.weight_kg is None or 0 < meta.weight_kg < 25
    assert np.all(np.abs(meta.points_m) < 3)


@SETTINGS
@given(key=st.sampled_from(["weight_lb", "accelerometer_mass_g", "temperature_c",
                            "tested_on"]), value=JSON_VALUES,
       nonfinite=st.sampled_from([None, "Infinity", "NaN", "1e999"]))
def test_retest_json_with_any_value(tmp_path, key, value, nonfinite):
    path = tmp_path / "retest.json"
    _write_json(path, {key: "__NONFINITE__" if nonfinite else value}, nonfinite)
    try:
        cond = read_retest_meta(path)
    except ValueError as exc:
        _one_line_error(exc, path)
        return
    for v in (cond.weight_kg, cond.sensor_mass_kg, cond.temperature_c):
        assert v is None or math.isfinite(v)


@SETTINGS
@given(row=st.integers(0, 5), col=st.integers(0, 1), junk=HOSTILE)
def test_profile_csv_with_a_cell_replaced(tmp_path, row, col, junk):
    rows = [["0", "1.2"], ["1", "1.2"], ["1", "0.8"], ["12", "0.9"], ["22", "1.8"],
            ["33", "2.6"]]
    rows[row][col] = junk
    path = tmp_path / "profile.csv"
    path.write_text("x_in,diameter_in\n" + "\n".join(",".join(r) for r in rows) + "\n")
    try:
        prof = read_profile_csv(path)
    except ValueError as exc:
        _one_line_error(exc, path)
        return
    assert np.all(np.isfinite(prof.x_m)) and np.all(prof.diameter_m > 0)
    assert prof.length_m < 5.0
