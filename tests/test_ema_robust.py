"""The fit on awkward tests (issue 13): one FRF, two nodes, no driving point, several
references, heavily damped modes whose peaks move between the points, close pairs, per-mode
warnings, and a fit that finds nothing saying why."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from batlab.cli import main
from ema.io.frf_data import FrfTest
from ema.modal_fit import fit_test
from ema.mode_checks import mode_warnings
from ema.shapes.mac import mac
from rigs.modal_model import ModalModel
from tests.ema_synthetic import make_inconsistent_test, make_test

FREQ = np.arange(0.0, 1600.5, 0.5)
X = np.linspace(0.02, 0.84, 9)


def _model(f=(151.0, 548.0, 961.0), z=(0.005, 0.008, 0.01)) -> ModalModel:
    shapes = 1.3 * np.stack([np.cos((i + 1.5) * np.pi * X / 0.86 + 0.2) for i in range(len(f))],
                            1)
    return ModalModel(np.array(f), np.array(z), shapes, X)


def _test(model, resp, ref, noise=0.002, seed=0, freq=FREQ):
    rng = np.random.default_rng(seed)
    h = model.accelerance(freq, resp, ref)
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=0, keepdims=True))
    h = h + noise * rms * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    nodes = np.arange(1, X.size + 1)
    return FrfTest(freq, h, nodes[list(resp)], nodes[list(ref)],
                   dict(zip(nodes.tolist(), X.tolist(), strict=True)))


def test_one_frf_and_two_nodes_fit_without_crash():
    model = _model()
    one = fit_test(_test(model, [7], [7]))
    np.testing.assert_allclose(one.freq_hz, model.freq_hz, rtol=2e-4)
    np.testing.assert_allclose(one.damping_ratio, model.damping_ratio, rtol=0.05)
    # the driving-point residue alone gives phi_d exactly (mass-normalised)
    np.testing.assert_allclose(np.abs(one.real_shapes[0]), np.abs(model.shapes[7]), rtol=0.02)
    assert one.rigid_body.mass_kg is None  # one node: no mass, at most a bound
    two = fit_test(_test(model, [7], [2, 7]))
    np.testing.assert_allclose(two.freq_hz, model.freq_hz, rtol=2e-4)
    np.testing.assert_allclose(two.real_shapes, model.shapes[[2, 7]] * np.sign(model.shapes[7]),
                               rtol=0.02, atol=0.01)


def test_no_driving_point_gives_unscaled_shapes_flagged():
    model = _model()
    fit = fit_test(_test(model, [7], [0, 1, 2, 3, 4, 5]))  # accelerometer at 8, never hit
    assert not fit.scaled and fit.driving_index is None and fit.driving_frf is None
    assert "no driving point" in fit.notes[0]
    np.testing.assert_allclose(fit.freq_hz, model.freq_hz, rtol=2e-4)
    assert np.all(np.diag(mac(fit.real_shapes, model.shapes[:6])) > 0.999)
    np.testing.assert_allclose(np.max(np.abs(fit.real_shapes), axis=0), 1.0, rtol=1e-3)
    assert fit.rigid_body.mass_kg is None and fit.rigid_body.mass_upper_bound_kg is None


def test_polyreference_three_responses():
    """Several references (3 accelerometers x 9 impacts): the same modes and scaled shapes."""
    model = _model()
    fit = fit_test(_test(model, [1, 4, 7], list(range(9))))
    np.testing.assert_allclose(fit.freq_hz, model.freq_hz, rtol=2e-4)
    expected = model.shapes * np.sign(model.shapes[1])[None, :]
    np.testing.assert_allclose(fit.real_shapes, expected, rtol=0.02, atol=0.01)


@pytest.mark.parametrize("seed", range(6))
def test_heavily_damped_inconsistent_modes_found_or_explained(seed):
    """3-7 % damping, peaks moving +-1 % between the points (2 % spread), 1 % noise: every
    mode is found (1.5 % in frequency, 25 % in damping) or its rejection says why; nothing is
    invented; all five found here (the peak-confirmed rescue finds the 6-7 % ones)."""
    test, f, z = make_inconsistent_test(seed)
    fit = fit_test(test)
    found = [np.flatnonzero(np.abs(fit.freq_hz / fr - 1) < 0.015) for fr in f]
    for fr, zr, k in zip(f, z, found, strict=True):
        if k.size:
            assert abs(fit.damping_ratio[k[0]] / zr - 1) < 0.25
        else:
            assert any(abs(r.freq_hz / fr - 1) < 0.03 for r in fit.rejected), (fr, fit.rejected)
    assert sum(k.size > 0 for k in found) == 5  # measured: all found on these six seeds
    assert fit.freq_hz.size == sum(k.size for k in found)  # none invented


def test_close_pair_resolved_with_own_shapes():
    """Two modes 0.5 % apart (light damping, different shapes): both found, reported as a
    pair with their separation."""
    shapes = 1.3 * np.stack([np.cos(2.5 * np.pi * X / 0.86 + 0.2),
                             np.sin(2.5 * np.pi * X / 0.86 + 0.7)], 1)
    model = ModalModel(np.array([548.0, 548.0 * 1.005]), np.array([0.001, 0.0012]), shapes, X)
    fit = fit_test(_test(model, [7], list(range(9)), freq=np.arange(0.0, 1600.25, 0.25)))
    np.testing.assert_allclose(fit.freq_hz, model.freq_hz, rtol=2e-4)
    assert np.all(np.diag(mac(fit.real_shapes, model.shapes)) > 0.99)
    (pair,) = fit.close_pairs
    assert (pair.i, pair.j) == (0, 1) and pair.separation == pytest.approx(0.005, rel=0.02)


def test_warnings_under_resolved_damping_leakage_coherence():
    f = np.array([100.0, 1000.0])
    z = np.array([0.001, 0.02])
    coh = np.ones((201, 1, 1))
    cf = np.linspace(0, 2000, 201)
    coh[np.abs(cf - 1000) < 30] = 0.5
    w = mode_warnings(f, z, 1.0, coh, cf)
    assert [m.split(":")[0] for m in w[0]] == ["under-resolved damping", "leakage"]
    assert [m.split(":")[0] for m in w[1]] == ["low coherence"]


@settings(max_examples=15, deadline=None)
@given(zeta=st.floats(1e-4, 0.05), f=st.floats(20.0, 3000.0), df=st.floats(0.1, 4.0))
def test_warning_thresholds_follow_their_equations(zeta, f, df):
    (w,) = mode_warnings(np.array([f]), np.array([zeta]), df)
    kinds = [m.split(":")[0] for m in w]
    assert ("under-resolved damping" in kinds) == (2 * zeta * f < df)
    assert ("leakage" in kinds) == (np.exp(-2 * np.pi * zeta * f / df) > 0.05)


def test_cli_json_explains_and_empty_fit_says_why(tmp_path, capsys):
    from ema.io.uff import write_uff

    model = _model()
    path = tmp_path / "t.uff"
    write_uff(path, _test(model, [7], [0, 1, 2, 3]))  # no driving point
    assert main(["fit", str(path), "--json"]) == 0
    cap = capsys.readouterr()
    doc = json.loads(cap.out)
    assert doc["scaled"] is False and doc["driving_point_node"] is None
    assert len(doc["modes"]) == 3 and all("warnings" in m for m in doc["modes"])
    assert {"rejected", "close_pairs", "notes"} <= doc.keys()
    assert "unscaled" in cap.err
    rng = np.random.default_rng(3)
    noise = rng.standard_normal((FREQ.size, 1, 4)) + 1j * rng.standard_normal((FREQ.size, 1, 4))
    nodes = np.arange(1, 5)
    write_uff(path, FrfTest(FREQ, noise, [1], nodes, {k: 0.1 * k for k in range(1, 5)}))
    assert main(["fit", str(path), "--json"]) == 0  # usable data, nothing in it: exit 0
    cap = capsys.readouterr()
    doc = json.loads(cap.out)
    assert doc["modes"] == [] and doc["notes"][-1].startswith("no mode:")
    assert "no mode:" in cap.err


@pytest.mark.parametrize("seed", [10, 11])
def test_a_mode_found_in_a_sub_band_is_found_in_the_full_band(seed):
    """Band consistency: sub-bands placed anywhere (edges not on the full band's sub-band
    cores) find no mode the full band lacks (within max(0.3 %, zeta) in frequency). Seed 10
    is a heavily damped, inconsistent test whose 2300 Hz mode the single-partition fit lost in
    the full band; 11 a bat-like test at 2 % noise."""
    test = make_inconsistent_test(seed)[0] if seed == 10 else make_test(seed, noise=0.02).test
    full = fit_test(test)
    for band in [(150.0, 500.0), (700.0, 1900.0), (1500.0, 2600.0), (2000.0, 3200.0)]:
        sub = fit_test(test, band_hz=band)
        for f, z in zip(sub.freq_hz, sub.damping_ratio, strict=True):
            assert np.any(np.abs(full.freq_hz / f - 1) < max(0.003, z)), (band, f, full.freq_hz)


def _off_axis_pair(split: float, zeta: float, angle: float = 0.4) -> tuple[FrfTest, ModalModel]:
    """A bat tapped off its grain axes: a 150 Hz mode and a bending mode seen in both planes,
    split by ``split``, each with the same pattern scaled by cos / sin of the tap angle."""
    base = 1.3 * np.cos(2.5 * np.pi * X15 / 0.86 + 0.2)
    shapes = np.stack([1.3 * np.cos(1.5 * np.pi * X15 / 0.86 + 0.2), base * np.cos(angle),
                       base * np.sin(angle)], 1)
    model = ModalModel(np.array([150.0, 560.0, 560.0 * (1 + split)]),
                       np.array([0.005, zeta, 1.1 * zeta]), shapes, X15)
    freq = np.arange(0.0, 1600.25, 0.25)
    rng = np.random.default_rng(0)
    h = model.accelerance(freq, [13], np.arange(15))
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=0, keepdims=True))
    white = (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)) / np.sqrt(2)
    h = h + 0.005 * rms * white
    nodes = np.arange(1, 16)
    return FrfTest(freq, h, nodes[[13]], nodes,
                   dict(zip(nodes.tolist(), X15.tolist(), strict=True))), model


X15 = np.linspace(0.02, 0.84, 15)


@pytest.mark.parametrize("split,zeta", [(0.01, 0.005), (0.03, 0.01), (0.06, 0.002)])
def test_off_axis_pairs_are_resolved_with_their_own_shapes(split, zeta):
    """Pairs split 1-6 % (modal overlap <= 1): both found, each shape the bending pattern
    scaled by its plane's factor (cos / sin of the tap angle), reported as a close pair."""
    test, model = _off_axis_pair(split, zeta)
    fit = fit_test(test)
    np.testing.assert_allclose(fit.freq_hz, model.freq_hz, rtol=2e-4)
    np.testing.assert_allclose(fit.real_shapes, model.shapes * np.sign(model.shapes[13]),
                               rtol=0.03, atol=0.02)
    (pair,) = fit.close_pairs
    assert (pair.i, pair.j) == (1, 2) and pair.separation == pytest.approx(split, rel=0.02)
    assert pair.mac > 0.99  # the same pattern: only the scale tells the planes apart


def test_unresolved_pair_is_said_to_be_merged():
    """A 0.3 % pair at 0.2 % damping: the second pole is seen at some orders but lacks
    support; the one mode reported says it may be a merged pair."""
    test, model = _off_axis_pair(0.003, 0.002)
    fit = fit_test(test)
    if fit.freq_hz.size == 3:  # resolved after all: then it must be right
        np.testing.assert_allclose(fit.freq_hz, model.freq_hz, rtol=2e-4)
    else:
        k = int(np.argmin(np.abs(fit.freq_hz - 560.0)))
        assert any(w.startswith("possibly merged pair") for w in fit.warnings[k])


def test_unusable_data_exit_2_with_one_line(tmp_path, capsys):
    """Data that cannot hold a mode (all zero; ending below the default band) is an error:
    exit 2, one line naming the problem, nothing on stdout."""
    from ema.io.uff import write_uff

    nodes = np.arange(1, 5)
    x = {k: 0.1 * k for k in range(1, 5)}
    cases = [(FrfTest(FREQ, np.zeros((FREQ.size, 1, 4), complex), [1], nodes, x),
              "every FRF is zero"),
             (FrfTest(FREQ[:30], np.ones((30, 1, 4), complex), [1], nodes, x),
              "below the default band start")]
    for test, message in cases:
        path = tmp_path / "bad.uff"
        write_uff(path, test)
        assert main(["fit", str(path), "--json"]) == 2
        cap = capsys.readouterr()
        assert cap.out == "" and message in cap.err.strip().splitlines()[-1]


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(100, 10_000), shift=st.floats(0.0, 0.02))
def test_damped_inconsistent_modes_never_silently_lost(seed, shift):
    """Any peak spread up to 2 % and any 3-7 % damping: each true mode is found (1.5 %) or
    listed in ``rejected`` near it (3 %), and no mode is invented."""
    test, f, _ = make_inconsistent_test(seed, shift=shift)
    fit = fit_test(test)
    for fr in f:
        found = np.any(np.abs(fit.freq_hz / fr - 1) < 0.015)
        assert found or any(abs(r.freq_hz / fr - 1) < 0.03 for r in fit.rejected), fr
    matched = [np.any(np.abs(f / fm - 1) < 0.015) for fm in fit.freq_hz]
    assert all(matched), fit.freq_hz
