"""FRF-level simulation of an impact test: exact modal FRFs plus measurement noise.

Measured FRFs are modelled as  H_meas = H (1 + e_rel n_1) + e_floor s n_2  with n_1, n_2
unit-variance circular complex Gaussian noise, e_rel the multiplicative (gain/phase) noise,
and a floor proportional to the FRF's own RMS level s (leakage, ADC and hammer noise).
"""

from __future__ import annotations

import numpy as np

from rigs.modal_model import ModalModel


def complex_noise(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Draw circular complex Gaussian samples with unit variance."""
    return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)


def simulate_frf(
    model: ModalModel, freq_hz: np.ndarray, resp: np.ndarray, ref: np.ndarray,
    rel_noise: float = 0.005, floor_noise: float = 1e-3, seed: int | None = None,
    resp_shapes: np.ndarray | None = None,
) -> np.ndarray:
    """Simulate a noisy accelerance H[f, i, j] between response and reference rows.

    Parameters
    ----------
    model : ModalModel
        Modal model at the test points.
    freq_hz : np.ndarray
        (F,) frequency lines, Hz.
    resp, ref : np.ndarray
        Indices into the model's points of the responses and the references.
    rel_noise : float, optional
        Multiplicative noise (0.005 = 0.5 %).
    floor_noise : float, optional
        Additive noise floor as a fraction of each FRF's RMS magnitude.
    seed : int or None, optional
        Seed of the noise generator (reproducible).
    resp_shapes : np.ndarray or None, optional
        (n_resp, m) shapes to use for the responses instead of the model's rows (a sensor
        sitting off the labelled point).

    Returns
    -------
    np.ndarray
        (F, n_resp, n_ref) complex accelerance, (m/s^2)/N, with noise (``add_noise``).
    """
    if resp_shapes is not None:
        shapes = np.vstack([model.shapes, resp_shapes])
        model = ModalModel(model.freq_hz, model.damping_ratio, shapes,
                           np.concatenate([model.x_m, np.full(len(resp_shapes), np.nan)]))
        resp = model.x_m.size - len(resp_shapes) + np.arange(len(resp_shapes))
    return add_noise(model.accelerance(freq_hz, resp, ref), rel_noise, floor_noise, seed)


def add_noise(
    h: np.ndarray, rel_noise: float, floor_noise: float, seed: int | None = None,
) -> np.ndarray:
    """Add multiplicative and floor noise to FRFs: H (1 + e_rel n_1) + e_floor s n_2.

    Parameters
    ----------
    h : np.ndarray
        (F, ...) FRFs, frequency on the first axis.
    rel_noise : float
        e_rel, the multiplicative noise (0.005 = 0.5 %).
    floor_noise : float
        e_floor, the floor as a fraction of s, the RMS of each FRF over f.
    seed : int or None, optional
        Seed of the noise generator; n_1, n_2 are unit circular complex Gaussians.

    Returns
    -------
    np.ndarray
        The noisy FRFs, complex, the shape of ``h``.
    """
    h = np.asarray(h, dtype=complex)
    rng = np.random.default_rng(seed)
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=0, keepdims=True))
    return (h * (1 + rel_noise * complex_noise(rng, h.shape))
            + floor_noise * rms * complex_noise(rng, h.shape))


def noise_coherence(
    h: np.ndarray, rel_noise: float, floor_noise: float, n_averages: int,
) -> np.ndarray:
    """Return the ordinary coherence an H1 estimate with ``add_noise``'s noise would show.

    ``add_noise`` gives the averaged estimate a relative complex variance
    v = e_rel^2 + e_floor^2 s^2 / |H|^2; an H1 estimate from n_d hits has
    v = (1 - gamma^2) / (gamma^2 n_d) (Bendat and Piersol 9.90), so

        gamma^2 = 1 / (1 + n_d v).

    Parameters
    ----------
    h : np.ndarray
        (F, ...) noise-free FRFs, frequency on the first axis.
    rel_noise, floor_noise : float
        e_rel and e_floor of ``add_noise``.
    n_averages : int
        Hits averaged (n_d).

    Returns
    -------
    np.ndarray
        gamma^2, the shape of ``h``, in (0, 1].

    Examples
    --------
    >>> h = np.ones((4, 1, 2), dtype=complex)
    >>> float(noise_coherence(h, 0.1, 0.0, 5)[0, 0, 0])
    0.9523809523809523
    """
    h = np.asarray(h, dtype=complex)
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=0, keepdims=True))
    power = np.maximum(np.abs(h) ** 2, 1e-300)
    v = rel_noise**2 + floor_noise**2 * rms**2 / power
    return 1.0 / (1.0 + n_averages * v)
