"""UFF FRF and mode files: round trips, pyuff interoperability, units, and every error path."""

from __future__ import annotations

import re
import struct

import numpy as np
import pytest
import pyuff
from hypothesis import given, settings
from hypothesis import strategies as st

from ema.io.frf_data import FrfTest
from ema.io.frf_io import read_test, require_driving_point, write_test
from ema.io.uff import read_uff, write_uff
from ema.io.uff_modes import read_modes_uff, write_modes_uff
from rigs.modal_model import ModalModel
from tests.frf_fixtures import bat_test

IN_PER_M = 1 / 0.0254
LBF_PER_N = 1 / 4.4482216152605


def _assert_same_test(a: FrfTest, b: FrfTest, rtol: float) -> None:
    np.testing.assert_array_equal(a.response_nodes, b.response_nodes)
    np.testing.assert_array_equal(a.reference_nodes, b.reference_nodes)
    np.testing.assert_array_equal(a.freq_hz, b.freq_hz)
    assert a.quantity == b.quantity
    assert a.exp_window_tau_s == b.exp_window_tau_s
    if rtol == 0:
        np.testing.assert_array_equal(a.frf, b.frf)
    else:
        np.testing.assert_allclose(a.frf.real, b.frf.real, rtol=rtol, atol=0)
        np.testing.assert_allclose(a.frf.imag, b.frf.imag, rtol=rtol, atol=0)
    assert sorted(a.node_x_m) == sorted(b.node_x_m)
    for n, x in a.node_x_m.items():  # dataset 15 prints E13.5
        assert b.node_x_m[n] == pytest.approx(x, rel=1e-5)


def test_binary_round_trip_is_bit_exact(tmp_path):
    t = bat_test(coherence=True)
    p = tmp_path / "t.uff"
    write_uff(p, t, binary=True)
    r = read_uff(p)
    _assert_same_test(t, r, rtol=0)
    np.testing.assert_array_equal(r.coherence, t.coherence)
    assert r.meta["estimator"] == "H1" and r.meta["uff_binary"] and r.meta["units"] == "SI"
    assert r.driving_point == (0, t.reference_nodes.size - 1)


def test_ascii_round_trip_to_print_precision(tmp_path):
    t = bat_test()
    p = tmp_path / "t.uff"
    write_uff(p, t, binary=False)
    r = read_uff(p)
    _assert_same_test(t, r, rtol=1e-11)  # pyuff prints 12 significant digits
    assert not r.meta["uff_binary"] and r.coherence is None


def test_odd_frequency_step_survives_through_the_axis_tokens(tmp_path):
    t = bat_test(n_lines=301, df_hz=10240 / 20971)  # not representable in E13.5
    write_uff(tmp_path / "t.uff", t)
    np.testing.assert_array_equal(read_uff(tmp_path / "t.uff").freq_hz, t.freq_hz)


@pytest.mark.parametrize("binary", [True, False])
def test_pyuff_alone_reads_what_batlab_writes(tmp_path, binary):
    t = bat_test(coherence=True)
    p = tmp_path / "t.uff"
    write_uff(p, t, binary=binary)
    sets = pyuff.UFF(str(p)).read_sets()
    assert [s["type"] for s in sets[:2]] == [164, 15]
    assert sets[0]["units_code"] == 1 and sets[0]["length"] == 1.0 and sets[0]["force"] == 1.0
    x = dict(zip(np.asarray(sets[1]["node_nums"], int).tolist(), sets[1]["x"], strict=True))
    assert x == pytest.approx(t.node_x_m, rel=1e-5)
    assert np.all(np.asarray(sets[1]["y"]) == 0) and np.all(np.asarray(sets[1]["z"]) == 0)
    frfs = [s for s in sets if s["type"] == 58 and s["func_type"] == 4]
    cohs = [s for s in sets if s["type"] == 58 and s["func_type"] == 6]
    assert len(frfs) == len(cohs) == t.reference_nodes.size
    for j, s in enumerate(frfs):
        assert (s["rsp_node"], s["rsp_dir"]) == (t.response_nodes[0], 3)
        assert (s["ref_node"], s["ref_dir"]) == (t.reference_nodes[j], 3)
        assert s["ordinate_spec_data_type"] == 12 and s["orddenom_spec_data_type"] == 13
        assert s["abscissa_spec_data_type"] == 18 and s["abscissa_spacing"] == 1
        np.testing.assert_allclose(s["x"], t.freq_hz, rtol=1e-12)
        np.testing.assert_allclose(s["data"], t.frf[:, 0, j], rtol=1e-10)
        np.testing.assert_allclose(cohs[j]["data"], t.coherence[:, 0, j], rtol=1e-10)
        assert "exp_window_tau_s=0.0625" in s["id4"] and "estimator=H1" in s["id4"]


def _foreign_file(path, test, units, binary, num_type=12, dirs=(3, 3), id4="NONE",
                  force_double=True, scale=1.0):
    """A UFF written by pyuff alone, in a unit system (code, length factor, force factor)."""
    code, lf, ff = units
    x = np.array([test.node_x_m[n] for n in sorted(test.node_x_m)])
    dsets = [
        {"type": 164, "units_code": code, "units_description": "foreign", "temp_mode": 1,
         "length": lf, "force": ff, "temp": 1.8, "temp_offset": 459.67},
        {"type": 15, "node_nums": np.array(sorted(test.node_x_m)), "x": x * lf,
         "y": np.zeros_like(x), "z": np.zeros_like(x)},
    ]
    for j, q in enumerate(test.reference_nodes):
        d = {"type": 58, "binary": int(binary), "func_type": 4,
             "rsp_node": int(test.response_nodes[0]), "rsp_dir": dirs[0],
             "ref_node": int(q), "ref_dir": dirs[1], "id4": id4,
             "abscissa_spacing": 1, "abscissa_spec_data_type": 18,
             "ordinate_spec_data_type": num_type, "orddenom_spec_data_type": 13,
             "data": test.frf[:, 0, j] * (lf / ff) * scale, "x": test.freq_hz}
        if not force_double:
            d["ord_data_type"] = 5
        dsets.append(d)
    pyuff.UFF(str(path)).write_sets(dsets, mode="overwrite", force_double=force_double)


@pytest.mark.parametrize("binary", [True, False])
@pytest.mark.parametrize("quantity,num_type", [("accelerance", 12), ("mobility", 11),
                                                ("receptance", 8)])
def test_inch_pound_file_reads_back_in_si(tmp_path, binary, quantity, num_type):
    t = bat_test(quantity=quantity)
    p = tmp_path / "inch.uff"
    _foreign_file(p, t, (7, IN_PER_M, LBF_PER_N), binary, num_type)
    r = read_uff(p)
    assert r.quantity == quantity and r.meta["units"] == "IN"
    np.testing.assert_allclose(r.frf, t.frf, rtol=1e-10)
    for n, x in t.node_x_m.items():
        assert r.node_x_m[n] == pytest.approx(x, rel=1e-5)


def test_millimetre_file_and_negative_direction_flip_sign(tmp_path):
    t = bat_test()
    p = tmp_path / "mm.uff"
    _foreign_file(p, t, (5, 1000.0, 1000.0), True, dirs=(-3, 3), id4="H2 estimate")
    r = read_uff(p)
    np.testing.assert_allclose(r.frf, -t.frf, rtol=1e-12)
    assert r.meta["estimator"] == "H2" and r.exp_window_tau_s is None


def test_fields_run_together_fall_back_to_pyuff(tmp_path):
    """Single precision E13.5 with 3-digit exponents leaves no blank between fields."""
    t = bat_test(n_lines=41)
    p = tmp_path / "tiny.uff"
    _foreign_file(p, t, (1, 1.0, 1.0), False, force_double=False, scale=-1e-110)
    assert re.search(r"\de-1\d\d-\d", p.read_text())  # fields really touch
    r = read_uff(p)
    np.testing.assert_allclose(r.frf, -1e-110 * t.frf, rtol=1e-5)


def test_uneven_spacing_record_with_even_values_is_accepted(tmp_path):
    t = bat_test(n_lines=201)
    p = tmp_path / "u.uff"
    write_uff(p, t, binary=False)
    sets = pyuff.UFF(str(p)).read_sets()
    for s in sets[2:]:
        s["abscissa_spacing"] = 0
    pyuff.UFF(str(tmp_path / "u2.uff")).write_sets(sets, mode="overwrite")
    r = read_uff(tmp_path / "u2.uff")
    np.testing.assert_allclose(r.freq_hz, t.freq_hz, atol=1e-9)
    np.testing.assert_allclose(r.frf, t.frf, rtol=1e-10)


def test_crlf_lines_and_big_endian_binary(tmp_path):
    t = bat_test(n_points=4, n_lines=101)
    p = tmp_path / "t.uff"
    write_uff(p, t, binary=False)
    p.write_bytes(p.read_bytes().replace(b"\n", b"\r\n"))
    np.testing.assert_allclose(read_uff(p).frf, t.frf, rtol=1e-11)
    write_uff(p, t, binary=True)
    raw = bytearray(p.read_bytes())
    pos = raw.find(b"    58b")
    while pos >= 0:  # byte order field 2 = big endian, and swap the data to match
        raw[pos + 7 : pos + 13] = b"     2"
        start = pos
        for _ in range(12):
            start = raw.find(b"\n", start) + 1
        n = 8 * 2 * t.freq_hz.size
        le = np.frombuffer(raw[start : start + n], "<f8")
        raw[start : start + n] = le.astype(">f8").tobytes()
        pos = raw.find(b"    58b", start + n)
    p.write_bytes(bytes(raw))
    np.testing.assert_array_equal(read_uff(p).frf, t.frf)


@settings(max_examples=12, deadline=None)
@given(
    nodes=st.lists(st.integers(1, 99999), min_size=2, max_size=7, unique=True),
    n_resp=st.integers(1, 2),
    n_lines=st.integers(2, 60),
    df=st.sampled_from([0.25, 0.5, 1.0, 0.48828125]),
    seed=st.integers(0, 2**16),
    binary=st.booleans(),
)
def test_random_node_sets_round_trip(tmp_path_factory, nodes, n_resp, n_lines, df, seed,
                                     binary):
    rng = np.random.default_rng(seed)
    n = len(nodes)
    x = np.sort(rng.uniform(0.0, 0.86, n))
    m = 3
    model = ModalModel(rng.uniform(5, 1500, m), rng.uniform(0.002, 0.05, m),
                       rng.normal(size=(n, m)), x)
    resp = np.arange(min(n_resp, n))
    f = np.arange(n_lines) * df + df * rng.integers(0, 3)
    t = FrfTest(f, model.accelerance(f, resp, np.arange(n)), np.array(nodes)[resp], nodes,
                dict(zip(nodes, x.tolist(), strict=True)))
    p = tmp_path_factory.mktemp("h") / "r.uff"
    write_uff(p, t, binary=binary)
    r = read_uff(p)
    _assert_same_test(t, r, rtol=0 if binary else 1e-11)
    require_driving_point(r, p)  # every response node is also an impact node here


def test_modes_round_trip_real_and_complex(tmp_path):
    rng = np.random.default_rng(3)
    f, z = np.array([152.0, 431.0, 805.0]), np.array([0.012, 0.009, 0.007])
    nodes, x = np.arange(11, 19), np.linspace(0.03, 0.8, 8)
    for shapes in (rng.normal(size=(8, 3)), rng.normal(size=(8, 3)) + 1j * rng.normal(size=(8, 3))):
        write_modes_uff(tmp_path / "m.uff", f, z, shapes, nodes, x)
        m = read_modes_uff(tmp_path / "m.uff")
        np.testing.assert_allclose(m.freq_hz, f, rtol=2e-6)  # E13.5: 6 digits
        np.testing.assert_allclose(m.damping_ratio, z, rtol=1e-4)
        np.testing.assert_allclose(m.shapes, shapes, atol=1e-5 * np.abs(shapes).max())
        np.testing.assert_array_equal(m.nodes, nodes)
        np.testing.assert_allclose(m.node_x_m, x, rtol=1e-5)
        assert np.iscomplexobj(m.shapes) == np.iscomplexobj(shapes)
    modes = [s for s in pyuff.UFF(str(tmp_path / "m.uff")).read_sets() if s["type"] == 55]
    assert [s["mode_n"] for s in modes] == [1, 2, 3]


# ----------------------------------------------------------------------------- error paths


def _written(tmp_path, binary=False, **kw):
    p = tmp_path / "bad.uff"
    write_uff(p, bat_test(**kw), binary=binary)
    return p


def _raises(path, *words):
    with pytest.raises(ValueError) as e:
        read_test(path)
    msg = str(e.value)
    assert str(path) in msg and "\n" not in msg
    for w in words:
        assert w in msg, msg
    return msg


def test_missing_file_is_oserror(tmp_path):
    with pytest.raises(OSError):
        read_uff(tmp_path / "nope.uff")


def test_garbage_and_empty_files(tmp_path):
    p = tmp_path / "g.uff"
    p.write_text("freq,re,im\n1,2,3\n")
    _raises(p, "not a UFF file")
    p.write_bytes(b"")
    _raises(p, "not a UFF file")
    p.write_bytes(bytes(range(256)) * 4)
    _raises(p, "not a UFF file")


@pytest.mark.parametrize("binary", [True, False])
def test_truncated_file(tmp_path, binary):
    p = _written(tmp_path, binary=binary)
    raw = p.read_bytes()
    cut = raw.rfind(b"    58") + (len(raw) - raw.rfind(b"    58")) // 2
    p.write_bytes(raw[:cut])
    msg = _raises(p, "truncated", "dataset #")
    assert f"#{2 + 8}" in msg  # the last (8th) FRF, after 164 and 15


def test_frequency_axes_that_differ(tmp_path):
    a, b = tmp_path / "a.uff", tmp_path / "b.uff"
    write_uff(a, bat_test(n_points=4, df_hz=0.5))
    write_uff(b, bat_test(n_points=4, df_hz=0.25, first_node=20))
    p = tmp_path / "ab.uff"
    p.write_bytes(a.read_bytes() + b.read_bytes())
    _raises(p, "frequency axis", "differs", "dataset #9")


def test_uneven_frequency_spacing(tmp_path):
    t = bat_test(n_lines=101)
    sets = []
    write_uff(tmp_path / "t.uff", t, binary=False)
    for s in pyuff.UFF(str(tmp_path / "t.uff")).read_sets():
        if s["type"] == 58:
            s["abscissa_spacing"] = 0
            s["x"] = s["x"].copy()
            s["x"][50:] += 0.5  # a missing line
        sets.append(s)
    p = tmp_path / "uneven.uff"
    pyuff.UFF(str(p)).write_sets(sets, mode="overwrite")
    _raises(p, "uneven frequency spacing", "dataset #3")


@pytest.mark.parametrize("binary", [True, False])
def test_nan_in_data(tmp_path, binary):
    p = _written(tmp_path, binary=binary)
    raw = bytearray(p.read_bytes())
    head = raw.find(b"    58")
    for _ in range(12):  # the 58 type line and its 11 header records
        head = raw.find(b"\n", head) + 1
    if binary:
        raw[head + 8 * 40 : head + 8 * 41] = struct.pack("<d", float("nan"))
    else:
        raw[head + 20 : head + 40] = b"%20s" % b"NaN"
    p.write_bytes(bytes(raw))
    _raises(p, "NaN or inf", "dataset #3")


def test_missing_node_in_dataset_15(tmp_path):
    p = _written(tmp_path)
    text = p.read_text()
    p.write_text(re.sub(r"\n +5 +0 +0 +0 [^\n]*", "", text, count=1))
    _raises(p, "node 5 is not defined in any dataset 15", "dataset #7")


def test_no_driving_point(tmp_path):
    t = bat_test(drive=False)
    p = tmp_path / "nodrive.uff"
    write_uff(p, t)
    assert read_uff(p).reference_nodes.size == 8  # the plain reader does not judge
    _raises(p, "no driving-point FRF")
    with pytest.raises(ValueError, match="where.uff"):
        require_driving_point(t, "where.uff")


def test_file_without_frfs(tmp_path):
    p = _written(tmp_path)
    raw = p.read_bytes()
    p.write_bytes(raw[: raw.find(b"    -1\n    58")])
    _raises(p, "no FRF")


def test_unknown_extension(tmp_path):
    with pytest.raises(ValueError, match=r"unknown FRF file type '\.txt'"):
        read_test(tmp_path / "t.txt")


def test_failed_write_leaves_old_file_and_no_temporaries(tmp_path):
    p = tmp_path / "keep.uff"
    write_test(p, bat_test())
    before = p.read_bytes()
    bad = bat_test()
    bad.frf[3, 0, 2] = np.nan
    with pytest.raises(ValueError, match="NaN or inf"):
        write_uff(p, bad)
    assert p.read_bytes() == before
    assert [q.name for q in tmp_path.iterdir()] == ["keep.uff"]


# pyuff's private extractors ema/io relies on: function, its parameters and the keys read.
PYUFF_PRIVATE = {
    15: ("dataset_15", "_extract15", ("block_data",), {"node_nums", "x"}),
    55: ("dataset_55", "_extract55", ("block_data",),
         {"analysis_type", "freq", "modal_damp_vis", "node_nums", "r3"}),
    58: ("dataset_58", "_extract58", ("block_data", "header_only"), {"data", "x"}),
    164: ("dataset_164", "_extract164", ("block_data",), {"length", "force", "units_code"}),
    2411: ("dataset_2411", "_extract2411", ("block_data",), {"node_nums", "x"}),
}


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(v) for v in re.findall(r"\d+", text)[:3])


def test_pyuff_is_in_the_pinned_range_whose_private_extractors_ema_io_uses(tmp_path):
    """pyproject.toml pins pyuff>=LO,<HI (docs/files.md says why); in that range the private
    ``_extract*`` functions exist with the parameters and return the keys ema/io uses."""
    import importlib
    import inspect
    from pathlib import Path

    from ema.io.uff_blocks import split_uff

    pyproject = (Path(__file__).resolve().parents[1] / "pyproject.toml").read_text()
    lo, hi = re.search(r'"pyuff>=([\d.]+),<([\d.]+)"', pyproject).groups()
    assert _version(lo) <= _version(pyuff.__version__) < _version(hi), pyuff.__version__
    extract = {}
    for dtype, (module, name, params, _) in PYUFF_PRIVATE.items():
        fn = getattr(importlib.import_module(f"pyuff.datasets.{module}"), name)
        assert tuple(inspect.signature(fn).parameters) == params, (name, params)
        extract[dtype] = fn
    write_uff(tmp_path / "t.uff", bat_test(n_points=3, n_lines=11), binary=False)
    write_modes_uff(tmp_path / "m.uff", np.array([150.0]), np.array([0.01]),
                    np.ones((3, 1)), np.arange(1, 4), np.array([0.1, 0.4, 0.8]))
    seen = set()
    for path in (tmp_path / "t.uff", tmp_path / "m.uff"):
        for b in split_uff(path.read_bytes(), path):
            keys = PYUFF_PRIVATE[b.type][3]
            assert keys <= set(extract[b.type](b.text.decode("latin-1") if b.type != 58
                                               else b.text)), b.type
            seen.add(b.type)
    assert seen == {15, 55, 58, 164}


def _scrambling_writer(monkeypatch, bad_writes):
    """pyuff's writer, scrambled on its first ``bad_writes`` calls as a late flush of an
    orphaned handle scrambles it: the file's last 200 bytes land in its middle."""
    real = pyuff.UFF.write_sets
    calls = {"n": 0}

    def write_sets(self, dsets, mode="add", force_double=True):
        real(self, dsets, mode=mode, force_double=force_double)
        calls["n"] += 1
        if calls["n"] <= bad_writes:
            with open(self._filename, "rb") as fh:
                data = fh.read()
            mid = len(data) // 2
            with open(self._filename, "wb") as fh:
                fh.write(data[:mid] + data[-200:] + data[mid:-200])

    monkeypatch.setattr(pyuff.UFF, "write_sets", write_sets)
    return calls


def test_a_write_that_does_not_read_back_is_written_again(tmp_path, monkeypatch):
    test = bat_test()
    calls = _scrambling_writer(monkeypatch, bad_writes=1)
    write_uff(tmp_path / "t.uff", test)
    assert calls["n"] == 2
    _assert_same_test(read_uff(tmp_path / "t.uff"), test, rtol=1e-12)


def test_a_write_that_never_reads_back_is_refused_and_nothing_is_left(tmp_path, monkeypatch):
    test = bat_test()
    _scrambling_writer(monkeypatch, bad_writes=5)
    with pytest.raises(OSError, match=r"t\.uff: the written UFF file does not read back"):
        write_uff(tmp_path / "t.uff", test)
    assert list(tmp_path.iterdir()) == []
