"""CSV and NPZ FRF files: exact round trips, agreement with UFF, and their error paths."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ema.io.frf_csv import read_frf_csv
from ema.io.frf_io import read_test, write_test
from tests.frf_fixtures import bat_test


@pytest.mark.parametrize("ext", [".csv", ".npz", ".uff"])
def test_round_trip_through_every_form(tmp_path, ext):
    t = bat_test(n_lines=201, coherence=True)
    p = tmp_path / f"t{ext}"
    write_test(p, t)
    r = read_test(p)
    np.testing.assert_array_equal(r.freq_hz, t.freq_hz)
    np.testing.assert_array_equal(r.frf, t.frf)
    np.testing.assert_array_equal(r.coherence, t.coherence)
    np.testing.assert_array_equal(r.response_nodes, t.response_nodes)
    np.testing.assert_array_equal(r.reference_nodes, t.reference_nodes)
    assert r.exp_window_tau_s == t.exp_window_tau_s and r.quantity == t.quantity
    assert r.meta["estimator"] == "H1" and r.meta["format"] == ext[1:]
    tol = 1e-5 if ext == ".uff" else 0  # dataset 15 keeps 6 digits
    assert r.node_x_m == pytest.approx(t.node_x_m, rel=tol)


def test_csv_layout_is_plain_long_table(tmp_path):
    t = bat_test(n_points=3, n_lines=5, quantity="mobility")
    p = tmp_path / "t.csv"
    write_test(p, t)
    lines = p.read_text().splitlines()
    assert "# quantity=mobility" in lines and "# exp_window_tau_s=0.0625" in lines
    df = pd.read_csv(p, comment="#")
    assert list(df.columns) == ["freq_hz", "response_node", "response_x_m", "reference_node",
                                "reference_x_m", "real", "imag"]
    assert len(df) == 3 * 5
    row = df.iloc[7]  # second FRF, third line
    j = list(t.reference_nodes).index(row.reference_node)
    assert row.real + 1j * row.imag == t.frf[2, 0, j]
    assert row.reference_x_m == t.node_x_m[int(row.reference_node)]


def test_hand_written_csv(tmp_path):
    """The minimal form a person would type: no comments, accelerance assumed."""
    p = tmp_path / "hand.csv"
    p.write_text(
        "freq_hz,response_node,response_x_m,reference_node,reference_x_m,real,imag\n"
        "0,2,0.80,1,0.10,0,0\n0.5,2,0.80,1,0.10,-1e-3,2e-4\n1.0,2,0.80,1,0.10,-4e-3,1e-3\n"
        "0,2,0.80,2,0.80,0,0\n0.5,2,0.80,2,0.80,-2e-3,3e-4\n1.0,2,0.80,2,0.80,-8e-3,2e-3\n"
    )
    t = read_test(p)
    assert t.quantity == "accelerance" and t.frf.shape == (3, 1, 2) and t.driving_point == (0, 1)
    assert t.node_x_m == {2: 0.8, 1: 0.1}
    assert t.frf[2, 0, 1] == -8e-3 + 2e-3j


def _csv(tmp_path, edit):
    p = tmp_path / "bad.csv"
    write_test(p, bat_test(n_points=3, n_lines=6))
    edit(pd.read_csv(p, comment="#")).to_csv(p, index=False)
    return p


def _set(row, col, value):
    def edit(d):
        d = d.astype({col: object}) if isinstance(value, str) else d
        d.loc[row, col] = value
        return d

    return edit


@pytest.mark.parametrize(
    "edit,words",
    [
        (lambda d: d.drop(columns="imag"), "missing columns ['imag']"),
        (_set(4, "real", np.nan), "NaN or inf"),
        (_set(3, "freq_hz", 1.9), "uneven frequency spacing"),
        (_set(8, "reference_x_m", 0.5), "more than one position"),
        (lambda d: d.drop(index=range(12, 18)), "no driving-point FRF"),
        (_set(slice(6, 11), "freq_hz", np.arange(6) * 0.25), "frequency axis differs"),
        (_set(2, "real", "abc"), "non-numeric"),
    ],
)
def test_csv_errors_name_the_file(tmp_path, edit, words):
    p = _csv(tmp_path, edit)
    with pytest.raises(ValueError) as e:
        read_test(p)
    assert str(p) in str(e.value) and words in str(e.value), str(e.value)


def test_csv_garbage(tmp_path):
    p = tmp_path / "g.csv"
    p.write_bytes(b"\x00\x01\x02 not,a,table\n")
    with pytest.raises(ValueError, match="not an FRF CSV file"):
        read_frf_csv(p)


def test_npz_errors_name_the_file(tmp_path):
    p = tmp_path / "g.npz"
    p.write_text("not a zip")
    with pytest.raises(ValueError, match="not a readable .npz"):
        read_test(p)
    np.savez(p, freq_hz=np.arange(3.0))
    with pytest.raises(ValueError, match=r"g\.npz: not an FRF archive \(missing arrays"):
        read_test(p)
