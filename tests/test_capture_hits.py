"""Hit simulation: exact modal superposition checked against numerical integration."""

import numpy as np
from scipy.integrate import solve_ivp

from rigs import protocol as p
from rigs.hits import Pulse, hammer_force, quantise, response_acceleration, simulate_hit
from rigs.modal_model import ModalModel

MODEL = ModalModel([150.0, 610.0, 1400.0], [0.01, 0.02, 0.015],
                   [[0.9, 0.7, 0.5], [-0.4, 0.8, -1.1]], [0.1, 0.7])


def test_response_matches_ode_integration_of_the_physical_system():
    pulses = [Pulse(0.002, 0.0011, 120.0), Pulse(0.0071, 0.0009, 40.0)]  # a double hit
    t = np.linspace(0, 0.03, 601)
    a = response_acceleration(MODEL, 1, 0, t, pulses)
    w = 2 * np.pi * MODEL.freq_hz
    z = MODEL.damping_ratio
    gain = MODEL.shapes[0] * MODEL.shapes[1]

    def rhs(tt, y):
        q, v = y[:3], y[3:]
        f = hammer_force(np.array([tt]), pulses)[0]
        return np.r_[v, f - 2 * z * w * v - w**2 * q]

    sol = solve_ivp(rhs, (0, 0.03), np.zeros(6), t_eval=t, rtol=1e-10, atol=1e-13,
                    max_step=2e-5)
    q, v = sol.y[:3], sol.y[3:]
    acc = (hammer_force(t, pulses)[None] - 2 * (z * w)[:, None] * v - (w**2)[:, None] * q)
    ref = gain @ acc
    np.testing.assert_allclose(a, ref, atol=1e-6 * np.abs(ref).max())


def test_short_pulse_tends_to_the_impulse_response_and_reciprocity():
    impulse = 0.2  # N s
    dur = 2e-5
    pulse = Pulse(0.0, dur, impulse * np.pi / (2 * dur))
    t = np.linspace(0.001, 0.02, 200)
    a = response_acceleration(MODEL, 1, 0, t, [pulse])
    w = 2 * np.pi * MODEL.freq_hz
    z = MODEL.damping_ratio
    wd = w * np.sqrt(1 - z**2)
    lam = -z * w + 1j * wd
    h_dd = np.imag(lam**2 * np.exp(lam * (t[:, None] - dur / 2))) / wd  # impulse response q''
    ref = impulse * h_dd @ (MODEL.shapes[0] * MODEL.shapes[1])
    np.testing.assert_allclose(a, ref, atol=2e-3 * np.abs(ref).max())
    np.testing.assert_array_equal(a, response_acceleration(MODEL, 0, 1, t, [pulse]))


def test_adc_model_codes_clip_and_flag():
    info = p.DeviceInfo((p.Channel("force", "N", 2.0), p.Channel("acceleration", "g", 1.0)),
                        10000.0, 24, 5.0)
    si = np.array([[100.0, 9.80665], [2600.0, 0.0], [-10.0, -5100 * 9.80665]])
    codes, over = quantise(si, info, 0.0, np.random.default_rng(0))
    v_per_code = 5.0 / 2**23
    assert codes[0, 0] == round(0.2 / v_per_code) and codes[0, 1] == round(1e-3 / v_per_code)
    assert codes[1, 0] == 2**23 - 1 and codes[2, 1] == -(2**23 - 1)
    np.testing.assert_array_equal(over, [False, True, True])
    codes, _ = simulate_hit(MODEL, 1, 0, info, 0.1, [Pulse(0.01, 0.001, 100.0)], 0.0)
    assert codes.shape == (1000, 2) and abs(codes[:, 0].max() * info.scale_si()[0] - 100) < 0.5
