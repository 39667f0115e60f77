"""The virtual bat test: simulated FRFs against independent physics."""

import numpy as np
import pytest
from scipy.signal import find_peaks

from rigs.modal_model import ModalModel
from rigs.virtual_test import simulate_frf
from updating.model.assembly import Attachment, assemble, build_model
from updating.model.material import Material
from updating.model.modes import model_modes
from updating.model.profile import paper_profile
from updating.model.units import IN_TO_M
from updating.simulate.virtual_bat import VirtualBat, simulate_test

WOOD = Material(12.5e9, 600.0, 14.0)
POINTS = np.arange(1, 34, 2) * IN_TO_M


def test_single_dof_accelerance_matches_analytic():
    m, k, c = 0.85, 3.2e6, 35.0  # kg, N/m, N s/m
    wn = np.sqrt(k / m)
    zeta = c / (2 * np.sqrt(k * m))
    f = np.linspace(1, 600, 2000)
    w = 2 * np.pi * f
    analytic = -w**2 / (k - m * w**2 + 1j * c * w)  # (m/s^2)/N of a mass on a spring
    model = ModalModel([wn / (2 * np.pi)], [zeta], [[1 / np.sqrt(m)]], [0.0])
    h = model.accelerance(f, [0], [0])[:, 0, 0]
    np.testing.assert_allclose(h, analytic, rtol=1e-12)


def test_fe_frf_matches_direct_solution_of_damped_equations():
    """Modal superposition (all modes) equals solving (K - w^2 M + i w C) x = F directly."""
    model = build_model(paper_profile(), WOOD, beam="timoshenko",
                        attachments=(Attachment(30 * IN_TO_M, mass_kg=0.004),
                                     Attachment(IN_TO_M, k_n_per_m=300.0),
                                     Attachment(32 * IN_TO_M, k_n_per_m=300.0)))
    modes = model_modes(model)
    zeta = np.full(modes.freq_hz.size, 0.01)
    K, M = assemble(model)
    wr = 2 * np.pi * modes.freq_hz
    phi = modes.shapes
    C = M @ phi @ np.diag(2 * zeta * wr) @ phi.T @ M  # the modal damping matrix
    f = np.array([50.0, 300.0, 1234.5])
    j, k = 2 * 5, 2 * 30
    direct = []
    for fi in f:
        w = 2 * np.pi * fi
        x = np.linalg.solve(K - w**2 * M + 1j * w * C, np.eye(model.n_dof)[:, k])
        direct.append(-w**2 * x[j])
    mm = ModalModel(modes.freq_hz, zeta, phi[[j, k]], [0.0, 1.0])
    np.testing.assert_allclose(mm.accelerance(f, [0], [1])[:, 0, 0], direct, rtol=1e-6)


def test_simulated_test_is_reciprocal_without_noise():
    quiet = dict(rel_noise=0.0, floor_noise=0.0, sensor_mass_kg=0.0)
    a = simulate_test(VirtualBat(paper_profile(), WOOD, POINTS, sensor_index=3, **quiet))
    b = simulate_test(VirtualBat(paper_profile(), WOOD, POINTS, sensor_index=12, **quiet))
    # H(3 <- 12) measured with the accelerometer at 3 equals H(12 <- 3) with it at 12
    np.testing.assert_allclose(a.frf[:, 0, 12], b.frf[:, 0, 3], rtol=1e-9, atol=1e-15)


def test_driving_point_peaks_at_model_frequencies():
    # light damping: the peak of |H| sits on the natural frequency, not pushed by neighbours
    bat = VirtualBat(paper_profile(), WOOD, POINTS, sensor_mass_kg=0.003, bungee_k_n_per_m=250,
                     rel_noise=0.0, floor_noise=0.0, zeta1=0.0005)
    test = simulate_test(bat, seed=3)
    i, j = test.driving_point
    h = np.abs(test.frf[:, i, j])
    f = test.freq_hz
    peaks, _ = find_peaks(h, prominence=0.05 * h.max())
    truth = model_modes(bat.truth_model(), 12).freq_hz
    expected = truth[(truth > 20) & (truth < f[-1])]
    found = f[peaks][f[peaks] > 20]
    assert found.size == expected.size
    np.testing.assert_allclose(found, expected, atol=0.5)  # within one frequency line


def test_noise_is_seeded_and_of_stated_size():
    bat = VirtualBat(paper_profile(), WOOD, POINTS, rel_noise=0.01, floor_noise=0.0)
    a, b = simulate_test(bat, seed=7), simulate_test(bat, seed=7)
    np.testing.assert_array_equal(a.frf, b.frf)
    clean = simulate_test(VirtualBat(paper_profile(), WOOD, POINTS, rel_noise=0.0,
                                     floor_noise=0.0))
    ratio = a.frf[1:] / clean.frf[1:] - 1
    assert np.std(ratio) == pytest.approx(0.01, rel=0.05)  # complex noise, unit variance


def test_simulate_frf_floor_noise_scales_with_rms():
    model = ModalModel([100.0], [0.01], [[1.0], [0.5]], [0.0, 1.0])
    f = np.linspace(0, 400, 801)
    h = simulate_frf(model, f, [0], [1], rel_noise=0.0, floor_noise=0.02, seed=1)
    clean = model.accelerance(f, [0], [1])
    rms = np.sqrt(np.mean(np.abs(clean) ** 2))
    assert np.std(h - clean) == pytest.approx(0.02 * rms, rel=0.1)
