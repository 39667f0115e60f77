"""`batlab fit` end to end: a UFF test file of a known modal model -> JSON modes and UFF 55."""

import json

import numpy as np
import pytest

from batlab.cli import main
from ema.io.frf_data import FrfTest
from ema.shapes.mac import mac
from rigs.modal_model import ModalModel

uff = pytest.importorskip("ema.io.uff")  # the FRF file readers (branch uff) must be present


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    rng = np.random.default_rng(11)
    x = np.linspace(0.02, 0.84, 16)
    f = np.array([151.0, 548.0, 961.0, 1850.0, 2510.0])
    z = np.array([0.005, 0.0075, 0.009, 0.011, 0.013])
    shapes = np.stack([1.3 * np.cos((i + 1.5) * np.pi * x / 0.86 + 0.2) for i in range(5)], 1)
    model = ModalModel(f, z, shapes, x)
    freq = np.arange(6401) * 0.5
    h = model.accelerance(freq, [14], np.arange(16))
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=0, keepdims=True))
    h = h + 0.005 * rms * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    nodes = np.arange(1, 17)
    test = FrfTest(freq, h, nodes[[14]], nodes, dict(zip(nodes.tolist(), x.tolist(), strict=True)))
    path = tmp_path_factory.mktemp("fit") / "test.uff"
    uff.write_uff(path, test)
    return path, model


def test_fit_json_recovers_the_modes(case, capsys, tmp_path):
    path, model = case
    out = tmp_path / "modes.uff"
    assert main(["fit", str(path), "--json", "-o", str(out), "--plots", str(tmp_path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    f = np.array([m["frequency_hz"] for m in doc["modes"]])
    z = np.array([m["damping_ratio"] for m in doc["modes"]])
    np.testing.assert_allclose(f, model.freq_hz, rtol=1e-4)
    np.testing.assert_allclose(z, model.damping_ratio, rtol=0.05)
    shape = np.array([m["shape"]["real"] for m in doc["modes"]]).T
    assert doc["modes"][0]["shape"]["nodes"] == list(range(1, 17))
    assert np.all(np.diag(mac(shape, model.shapes)) > 0.999)
    assert doc["synthesis_error"]["total"] < 0.02
    from ema.io.uff_modes import read_modes_uff

    modes = read_modes_uff(out)
    np.testing.assert_allclose(modes.freq_hz, f, rtol=1e-5)
    np.testing.assert_allclose(np.abs(modes.shapes), np.abs(model.shapes), rtol=0.03, atol=0.02)
    for name in ("stabilisation.png", "synthesis.png", "automac.png"):
        assert (tmp_path / name).stat().st_size > 1000


def test_fit_table_and_peak_method(case, capsys):
    path, model = case
    assert main(["fit", str(path), "--method", "peak", "--band", "100", "3000"]) == 0
    text = capsys.readouterr().out
    assert "5 modes in 100-3000 Hz (peak" in text


def test_fit_bad_input_is_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "broken.uff"
    bad.write_text("not a universal file\n")
    assert main(["fit", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) >= 1 and err[-1].startswith("batlab fit: error:") and "broken.uff" in err[-1]
