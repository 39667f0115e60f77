"""Random modal models and their noisy FRF tests, for the ema hidden-effect tests."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema.io.frf_data import FrfTest
from rigs.modal_model import ModalModel


@dataclass(frozen=True)
class SyntheticTest:
    """A roving-hammer test of a known modal model and the modes the fit must find."""

    test: FrfTest
    model: ModalModel
    in_band: np.ndarray  # indices of model modes inside the fitted band
    band_hz: tuple[float, float]
    driving_index: int


def random_modes(
    rng: np.random.Generator,
    n_modes: int,
    n_points: int,
    band_hz: tuple[float, float] = (20.0, 3200.0),
    close_ratio: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (ascending, >= 4 % apart except one pair close_ratio apart) and damping.

    Damping is log-uniform in 0.3-3 %; the close pair's is capped at close_ratio (modal
    overlap zeta / separation <= 1: the pair shows two peaks or a shouldered one).
    """
    lo, hi = band_hz
    while True:
        f = np.sort(np.exp(rng.uniform(np.log(lo + 80.0), np.log(0.97 * hi), n_modes)))
        if np.all(np.diff(f) / f[:-1] > 0.04):
            break
    zeta = np.exp(rng.uniform(np.log(0.003), np.log(0.03), n_modes))
    if close_ratio is not None:
        k = int(rng.integers(0, n_modes - 1))
        f[k + 1] = f[k] * (1 + close_ratio)
        cap = min(0.03, close_ratio)
        zeta[k : k + 2] = np.exp(rng.uniform(np.log(0.003), np.log(cap), 2))
        order = np.argsort(f)
        f, zeta = f[order], zeta[order]
    return f, zeta


def make_test(
    seed: int,
    n_modes: int = 6,
    n_points: int = 17,
    noise: float = 0.005,
    close_ratio: float | None = 0.01,
    cut_mode: bool = True,
    quantity: str = "accelerance",
    df_hz: float = 0.5,
    f_max_hz: float = 3200.0,
    suspension: bool = True,
) -> SyntheticTest:
    """Roving-hammer FRFs of a random modal model, with complex Gaussian noise of RMS
    ``noise`` times each FRF's RMS over the axis.

    The model has ``n_modes`` modes in the band (20 Hz to f_max), optionally two ``close_ratio``
    apart, optionally one more just above f_max (0.2 to 2 % above: the end of the data cuts it),
    and optionally two suspension rigid-body modes below 10 Hz. Shapes are random with the
    driving point (the accelerometer, near the barrel end) well away from a node.
    """
    rng = np.random.default_rng(seed)
    band = (20.0, f_max_hz)
    f, zeta = random_modes(rng, n_modes, n_points, band, close_ratio)
    shapes = rng.standard_normal((n_points, n_modes)) * 1.5
    d = n_points - 2
    shapes[d] = np.sign(shapes[d] + 1e-12) * np.maximum(np.abs(shapes[d]), 1.0)
    x = np.sort(rng.uniform(0.02, 0.84, n_points))
    freqs, damp, cols = [f], [zeta], [shapes]
    if cut_mode:
        freqs.append([f_max_hz * (1 + rng.uniform(0.002, 0.02))])
        damp.append([rng.uniform(0.005, 0.02)])
        cols.append(rng.standard_normal((n_points, 1)) * 1.5)
    if suspension:
        mass, x_c, inertia = 0.9, 0.5, 0.045
        freqs.append([rng.uniform(2.0, 4.0), rng.uniform(5.0, 9.0)])
        damp.append([0.03, 0.03])
        # rotate the bounce/pitch pair: any orthonormal mix is a valid pair of rigid modes
        a = rng.uniform(0, np.pi)
        rb = np.stack([np.ones(n_points) / np.sqrt(mass), (x - x_c) / np.sqrt(inertia)], axis=1)
        rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        cols.append(rb @ rot)
    model = ModalModel(np.concatenate(freqs), np.concatenate(damp), np.hstack(cols), x)
    freq = np.arange(0.0, f_max_hz + df_hz / 2, df_hz)
    h = model.accelerance(freq, [d], np.arange(n_points))
    if quantity == "receptance":
        h = model.receptance(freq, [d], np.arange(n_points))
    elif quantity == "mobility":
        h = model.receptance(freq, [d], np.arange(n_points)) * (2j * np.pi * freq)[:, None, None]
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=0, keepdims=True))
    white = rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)
    h = h + noise * rms * white / np.sqrt(2)
    nodes = np.arange(1, n_points + 1)
    test = FrfTest(
        freq_hz=freq,
        frf=h,
        response_nodes=nodes[[d]],
        reference_nodes=nodes,
        node_x_m={int(k): float(v) for k, v in zip(nodes, x, strict=True)},
        quantity=quantity,
    )
    return SyntheticTest(test, model, np.arange(n_modes), band, d)


def make_inconsistent_test(
    seed: int, shift: float = 0.02, n_points: int = 12, noise: float = 0.01
) -> tuple[FrfTest, np.ndarray, np.ndarray]:
    """A heavily damped (3-7 %) roving-hammer test whose peaks move between the points.

    Five modes at 180-2300 Hz; each FRF's natural frequencies are scaled by its own factor
    1 + shift u, u uniform in -1/2..1/2 (the structure changed a little between impacts: a
    tool re-clamped, a wheel re-hung), 1 Hz lines to 3200 Hz, complex noise of ``noise`` x each
    FRF's RMS. Returns (test, true frequencies, true damping).
    """
    rng = np.random.default_rng(seed)
    f = np.array([180.0, 420.0, 900.0, 1500.0, 2300.0])
    z = rng.uniform(0.03, 0.07, f.size)
    x = np.linspace(0.02, 0.84, n_points)
    shapes = 1.3 * np.stack([np.cos((i + 1.5) * np.pi * x / 0.86 + 0.2) for i in range(f.size)], 1)
    freq = np.arange(0.0, 3200.5, 1.0)
    d = n_points - 2
    cols = [ModalModel(f * (1 + shift * rng.uniform(-0.5, 0.5)), z, shapes, x).accelerance(
        freq, [d], [j]) for j in range(n_points)]
    h = np.concatenate(cols, axis=2)
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=0, keepdims=True))
    white = rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)
    h = h + noise * rms * white / np.sqrt(2)
    nodes = np.arange(1, n_points + 1)
    test = FrfTest(freq, h, nodes[[d]], nodes,
                   {int(k): float(v) for k, v in zip(nodes, x, strict=True)})
    return test, f, z


def make_character_test(
    seed: int, freq_hz: np.ndarray, zeta: np.ndarray, gain: np.ndarray, shift: float = 0.0,
    n_points: int = 12, noise: float = 0.01, coherence_dip_hz: float | None = None,
) -> FrfTest:
    """A roving-hammer accelerance test of given modes, to 3200 Hz at 1 Hz, with coherence.

    Shapes are cosines of rising order scaled by ``gain`` (a weak mode: small gain); each FRF's
    natural frequencies are scaled by its own 1 + shift u, u uniform in -1/2..1/2 (peaks that
    move between the points); complex noise of ``noise`` x each FRF's RMS. The coherence is
    0.995 except, with ``coherence_dip_hz``, a null of the force spectrum there: +-8 lines where
    the FRF is noise of the FRF's own size and the coherence falls to 0.3.
    """
    rng = np.random.default_rng(seed)
    f, z, g = (np.asarray(v, dtype=float) for v in (freq_hz, zeta, gain))
    x = np.linspace(0.02, 0.84, n_points)
    shapes = np.stack([g[i] * 1.3 * np.cos((i + 1.5) * np.pi * x / 0.86 + 0.2)
                       for i in range(f.size)], 1)
    freq = np.arange(0.0, 3200.5, 1.0)
    d = n_points - 2
    cols = [ModalModel(f * (1 + shift * rng.uniform(-0.5, 0.5)), z, shapes, x).accelerance(
        freq, [d], [j]) for j in range(n_points)]
    h = np.concatenate(cols, axis=2)
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=0, keepdims=True))
    white = rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)
    h = h + noise * rms * white / np.sqrt(2)
    coh = np.full(h.shape, 0.995)
    if coherence_dip_hz is not None:
        dip = np.abs(freq - coherence_dip_hz) <= 8
        h[dip] = np.abs(h[dip]) * (rng.standard_normal(h[dip].shape) * 0.5 + 0.1)
        coh[dip] = 0.3
    nodes = np.arange(1, n_points + 1)
    return FrfTest(freq, h, nodes[[d]], nodes,
                   {int(k): float(v) for k, v in zip(nodes, x, strict=True)}, coherence=coh)
