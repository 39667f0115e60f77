"""Time-domain simulation of hammer hits on a modal model, exact at the sample instants.

Force: a sum of half-sine pulses f(t) = P sin(pi (t - t0) / T) for t0 <= t <= t0 + T.
Each mode r obeys q'' + 2 zeta_r w_r q' + w_r^2 q = f(t) (unit modal force; the physical
acceleration at point i for a hit at point j is sum_r phi_ir phi_jr q_r''). With
lambda = -zeta w + i w_d, the impulse response is h(t) = Im(exp(lambda t)) / w_d, h(0) = 0,
h'(0) = 1, so for a half-sine starting at 0

    q''(t) = f(t) + Im(lambda^2 exp(lambda t) I(t)) / w_d,
    I(t) = int_0^min(t,T) exp(-lambda s) sin(W s) ds,  W = pi / T,

and I(t) has the closed form (1/2i) [G(iW - lambda) - G(-iW - lambda)], G(a) = (e^{a u}-1)/a,
u = min(t, T). Evaluated on the sample grid: no time stepping, no discretisation error.
The ADC is modelled as volts = SI / SI-per-unit * sensitivity, plus Gaussian noise, rounded to
codes and clipped at full scale (anti-aliasing: modes above 0.45 fs are left out).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigs.modal_model import ModalModel
from rigs.protocol import DeviceInfo


@dataclass(frozen=True)
class Pulse:
    """One half-sine hammer pulse: start time s, duration s, peak force N."""

    t0_s: float
    duration_s: float
    peak_n: float


def hammer_force(t_s: np.ndarray, pulses: list[Pulse]) -> np.ndarray:
    """Return the force (N) of the half-sine pulses at times ``t_s`` (s)."""
    f = np.zeros_like(np.asarray(t_s, dtype=float))
    for pl in pulses:
        tau = t_s - pl.t0_s
        on = (tau >= 0) & (tau <= pl.duration_s)
        f[on] += pl.peak_n * np.sin(np.pi * tau[on] / pl.duration_s)
    return f


def modal_acceleration(t_s: np.ndarray, pulse: Pulse, freq_hz: np.ndarray,
                       damping_ratio: np.ndarray) -> np.ndarray:
    """Return q_r''(t) (m/s^2 per unit modal force gain), shape (len(t), n_modes), exact.

    Underdamped modes with w_r > 0 only (module docstring).
    """
    t = np.asarray(t_s, dtype=float)[:, None] - pulse.t0_s
    w = 2 * np.pi * np.asarray(freq_hz, dtype=float)[None, :]
    z = np.asarray(damping_ratio, dtype=float)[None, :]
    if np.any(w <= 0) or np.any(z >= 1):
        raise ValueError("hit simulation needs underdamped modes with positive frequency")
    wd = w * np.sqrt(1 - z**2)
    lam = -z * w + 1j * wd
    big_w = np.pi / pulse.duration_s
    u = np.clip(t, 0.0, pulse.duration_s)

    def g(a: np.ndarray) -> np.ndarray:
        return np.expm1(a * u) / a

    integral = (g(1j * big_w - lam) - g(-1j * big_w - lam)) / 2j
    tt = np.maximum(t, 0.0)
    acc = np.imag(lam**2 * np.exp(lam * tt) * integral) / wd
    force = np.where((t >= 0) & (t <= pulse.duration_s),
                     np.sin(big_w * np.clip(t, 0, None)), 0.0)
    return pulse.peak_n * (acc + force)


def response_acceleration(model: ModalModel, resp: int, ref: int, t_s: np.ndarray,
                          pulses: list[Pulse], fmax_hz: float = np.inf) -> np.ndarray:
    """Return the acceleration (m/s^2) at point ``resp`` for hits at point ``ref`` (indices)."""
    keep = model.freq_hz < fmax_hz
    gain = model.shapes[resp, keep] * model.shapes[ref, keep]
    a = np.zeros(np.asarray(t_s).shape)
    for pl in pulses:
        a += modal_acceleration(t_s, pl, model.freq_hz[keep], model.damping_ratio[keep]) @ gain
    return a


def quantise(si: np.ndarray, info: DeviceInfo, noise_v: float,
             rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Quantise SI signals (n, ch) to ADC codes (n, ch) int32 and overload flags (n,).

    volts = si / UNIT_TO_SI * sensitivity + noise; codes = round(volts / V_per_code) clipped to
    +-(2**(bits-1) - 1); overload where a code reaches full scale.
    """
    scale = info.scale_si()
    volts_per_code = info.adc_full_scale_v / 2 ** (info.bits - 1)
    noise = rng.normal(0.0, noise_v / volts_per_code, si.shape) if noise_v > 0 else 0.0
    codes = np.rint(si / scale + noise)
    fs = info.full_scale_code
    over = np.any(np.abs(codes) >= fs, axis=1)
    return np.clip(codes, -fs, fs).astype(np.int32), over


def simulate_hit(model: ModalModel, resp: int, ref: int, info: DeviceInfo, duration_s: float,
                 pulses: list[Pulse], noise_v: float = 0.0,
                 rng: np.random.Generator | None = None, t_start_s: float = 0.0
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Simulate the ADC record of one or more hammer hits on the modal model.

    Channel layout from ``info``: the first 'force' channel gets the hammer force, the first
    'acceleration' channel the response; any other channel is noise only.

    Parameters
    ----------
    model : ModalModel
        Mass-normalised modes at the test points.
    resp, ref : int
        Indices of the response (accelerometer) and impact points.
    info : DeviceInfo
        The device: sampling rate, ADC, channels and sensitivities.
    duration_s : float
        Record length, s.
    pulses : list of Pulse
        The hammer's half-sine pulses.
    noise_v : float, optional
        RMS electrical noise at the ADC input, V.
    rng : np.random.Generator, optional
        Noise generator (default seeded 0).
    t_start_s : float, optional
        Time of the record's first sample, s.

    Returns
    -------
    codes : np.ndarray
        (n, n_channels) int32 ADC codes.
    overload : np.ndarray
        (n,) bool, a code at full scale.
    """
    rng = rng or np.random.default_rng(0)
    n = int(round(duration_s * info.sample_rate_hz))
    t = t_start_s + np.arange(n) / info.sample_rate_hz
    si = np.zeros((n, info.n_channels))
    si[:, info.channel_index("force")] = hammer_force(t, pulses)
    si[:, info.channel_index("acceleration")] = response_acceleration(
        model, resp, ref, t, pulses, fmax_hz=0.45 * info.sample_rate_hz)
    return quantise(si, info, noise_v, rng)
