"""Impact capture: trigger, records, and every rejection reason on simulated hits."""

import re

import numpy as np
import pytest

from rigs import protocol as p
from rigs.capture import CaptureSettings, HitCapture, check_hit
from rigs.hits import Pulse, simulate_hit
from rigs.modal_model import ModalModel
from rigs.stream import DataBlock, Gap

FS = 4096.0
INFO = p.DeviceInfo((p.Channel("force", "N", 2.25), p.Channel("acceleration", "g", 1.0)), FS,
                    24, 5.0, 32)
MODEL = ModalModel([180.0, 520.0], [0.01, 0.012], [[0.9, 0.7], [-0.5, 0.8]], [0.1, 0.7])
SET = CaptureSettings(record_s=1.0, pretrigger_s=0.01)


def _blocks(codes, over=None, index0=0, spf=32):
    over = np.zeros(len(codes), bool) if over is None else over
    return [DataBlock(index0 + k, codes[k:k + spf], bool(over[k:k + spf].any()))
            for k in range(0, len(codes), spf)]


def _records(items, arm=0, settings=SET):
    cap = HitCapture(INFO, settings)
    cap.arm(arm)
    out = []
    for it in items:
        out += cap.push(it)
    return cap, out


def _verdicts(pulses, duration=3.0, model=MODEL, settings=SET, noise=1e-5):
    codes, over = simulate_hit(model, 1, 0, INFO, duration, pulses, noise,
                               np.random.default_rng(1))
    cap, recs = _records(_blocks(codes, over), settings=settings)
    return [check_hit(r, settings, FS, cap.n_pre) for r in recs], recs


def test_trigger_position_pretrigger_and_record_length():
    t0 = 0.5
    checks, recs = _verdicts([Pulse(t0, 0.001, 200.0)])
    assert len(recs) == 1 and checks[0].accepted and checks[0].reason is None
    r = recs[0]
    # force crosses 20 N where 200 sin(pi t / 1 ms) = 20
    t_cross = t0 + 1e-3 * np.arcsin(0.1) / np.pi
    assert r.trigger_index == int(np.ceil(t_cross * FS))
    assert r.index0 == r.trigger_index - round(0.01 * FS) and r.force_n.size == FS
    assert abs(r.force_n.max() - 200.0) < 2.0


def test_hysteresis_one_record_per_hit_and_taps_before_arming_ignored():
    pulses = [Pulse(0.2, 0.001, 150.0), Pulse(1.5, 0.001, 150.0), Pulse(2.8, 0.001, 150.0),
              Pulse(3.5, 0.001, 150.0), Pulse(3.515, 0.001, 80.0)]  # a double hit ...
    codes, over = simulate_hit(MODEL, 1, 0, INFO, 5.0, pulses, 1e-5)
    _, recs = _records(_blocks(codes, over), arm=int(1.0 * FS))
    assert [round(r.trigger_index / FS, 2) for r in recs] == [1.5, 2.8]
    # ... armed between its two pulses: the bounce does not start a record
    _, recs = _records(_blocks(codes, over), arm=int(3.508 * FS))
    assert recs == []


def test_double_hit_rejected_with_timing():
    checks, _ = _verdicts([Pulse(0.3, 0.001, 200.0), Pulse(0.312, 0.001, 60.0)])
    assert checks[0].reason == "double hit"
    dt_ms = float(re.search(r"([\d.]+) ms after", checks[0].detail).group(1))
    assert abs(dt_ms - 12.0) < 1e3 / FS + 0.05 and "30 % of its peak" in checks[0].detail


def test_single_ringing_hit_is_not_a_double_hit():
    # two overlapping half-sines = one longer, non-zero pulse: not a second hit
    checks, _ = _verdicts([Pulse(0.3, 0.001, 200.0), Pulse(0.3008, 0.001, 80.0)])
    assert checks[0].accepted


def test_overload_by_clipping_and_by_device_flag():
    fs_force = 5.0 / 2.25e-3
    checks, _ = _verdicts([Pulse(0.3, 0.001, 1.2 * fs_force)])
    assert checks[0].reason == "overload" and "device overload flag" in checks[0].detail
    # the flag alone (analog overload the ADC codes do not show)
    codes, over = simulate_hit(MODEL, 1, 0, INFO, 2.0, [Pulse(0.3, 0.001, 200.0)], 1e-5)
    over[int(0.35 * FS)] = True
    cap, recs = _records(_blocks(codes, over))
    assert check_hit(recs[0], SET, FS, cap.n_pre).reason == "overload"
    # a status message inside the record does the same
    cap, recs = _records([p.Status(int(0.4 * FS), p.STATUS_OVERLOAD, 2, 0, 0)]
                         + _blocks(codes))
    assert check_hit(recs[0], SET, FS, cap.n_pre).reason == "overload"


def test_force_too_weak():
    checks, _ = _verdicts([Pulse(0.3, 0.001, 35.0)])
    assert checks[0].reason == "force too weak" and "< 50.0 N" in checks[0].detail


def test_response_not_decayed():
    slow = ModalModel([180.0], [0.001], [[1.0], [1.0]], [0.1, 0.7])
    checks, _ = _verdicts([Pulse(0.3, 0.001, 200.0)], model=slow)
    assert checks[0].reason == "response not decayed"
    long_rec = CaptureSettings(record_s=6.0)
    checks, _ = _verdicts([Pulse(0.3, 0.001, 200.0)], duration=7.0, model=slow,
                          settings=long_rec)
    assert checks[0].accepted


def test_gap_inside_record_rejects_gap_outside_does_not():
    codes, over = simulate_hit(MODEL, 1, 0, INFO, 5.0, [Pulse(0.5, 0.001, 200.0),
                                                        Pulse(3.0, 0.001, 200.0)], 1e-5)
    blocks = _blocks(codes, over)
    lost = int(0.9 * FS) // 32  # a block inside the first record
    items = blocks[:lost] + [Gap(blocks[lost].index0, blocks[lost + 1].index0, "1 frame lost")]
    items += blocks[lost + 1:]
    far = int(2.0 * FS) // 32  # a lost non-data frame between the two records
    items.insert(far + 1, Gap(blocks[far].index0, blocks[far].index0, "1 frame(s) lost"))
    cap, recs = _records(items)
    verdicts = [check_hit(r, SET, FS, cap.n_pre) for r in recs]
    assert [v.reason for v in verdicts] == ["data lost", None]
    assert verdicts[0].detail == "1 frame lost"
    # the missing samples were not stitched: the record keeps its length and alignment
    assert recs[1].trigger_index == int(np.ceil((3.0 + 1e-3 * np.arcsin(0.1) / np.pi) * FS))


def test_stream_restart_inside_pretrigger_is_data_lost():
    quiet, _ = simulate_hit(MODEL, 1, 0, INFO, 0.5, [], 1e-5)
    codes, over = simulate_hit(MODEL, 1, 0, INFO, 2.0, [Pulse(0.001, 0.001, 200.0)], 1e-5)
    cap, recs = _records(_blocks(quiet) + _blocks(codes, over, index0=10**6))
    assert check_hit(recs[0], SET, FS, cap.n_pre).reason == "data lost"


@pytest.mark.parametrize("spf", [1, 7, 500])
def test_block_size_does_not_change_the_record(spf):
    codes, over = simulate_hit(MODEL, 1, 0, INFO, 2.0, [Pulse(0.4, 0.001, 200.0)], 1e-5)
    _, ref = _records(_blocks(codes, over, spf=32))
    _, got = _records(_blocks(codes, over, spf=spf))
    np.testing.assert_array_equal(ref[0].accel_ms2, got[0].accel_ms2)
