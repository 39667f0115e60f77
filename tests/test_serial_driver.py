"""The driver over pyserial's loop:// and over a pseudo-terminal, with every fault."""

import threading
import time

import numpy as np
import pytest
import serial

from rigs import protocol as p
from rigs.capture import CaptureSettings, HitCapture, check_hit
from rigs.driver import DeviceError, SerialDevice, open_port
from rigs.hits import Pulse, simulate_hit
from rigs.modal_model import uniform_beam_modes
from rigs.session import HitLog, acquire_point
from rigs.stream import DataBlock, Gap
from rigs.virtual_box import BoxConfig, VirtualBox, default_info

FS = 4096.0
INFO = p.DeviceInfo((p.Channel("force", "N", 2.25), p.Channel("acceleration", "g", 1.0)), FS,
                    24, 5.0, 32)
MODEL = uniform_beam_modes(0.86, 0.9, 175.0, np.array([0.1, 0.8]))
SET = CaptureSettings(record_s=1.0)


def _frames(codes, counter0=1, spf=32):
    return [p.encode_frame(p.DATA, counter0 + k, k * spf,
                           p.encode_samples(codes[k * spf:(k + 1) * spf], 24), p.data_flags(2, 24))
            for k in range(len(codes) // spf)]


def _hits(times_s, total_s):
    codes, _ = simulate_hit(MODEL, 1, 0, INFO, total_s, [Pulse(t, 0.001, 200.0) for t in times_s],
                            2e-5, np.random.default_rng(0))
    return codes


def _drain(dev, until=None, timeout_s=3.0):
    items, t_end = [], time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        it = dev.next_item(0.05)
        if it is not None:
            items.append(it)
            if until and until(it):
                break
    return items


def test_loop_stream_with_every_wire_fault(tmp_path):
    """Five hits; garbage before hit 1 costs nothing, a bit flip in hit 2, a dropped frame in
    hit 3 and a truncated frame in hit 4 reject exactly those; hit 5 is clean."""
    codes = _hits([0.2, 1.5, 2.8, 4.1, 5.4], 6.6)
    frames = _frames(codes)
    k2, k3, k4 = (int((t + 0.3) * FS) // 32 for t in (1.5, 2.8, 4.1))
    flipped = bytearray(frames[k2])
    flipped[40] ^= 0x10
    frames[k2] = bytes(flipped)
    frames[k3] = b""
    frames[k4] = frames[k4][:30]
    wire = b"\x00\xa5junk\xa5\x5a\x13" + b"".join(frames[:20]) + bytes(range(256)) + \
        b"".join(frames[20:])
    port = serial.serial_for_url("loop://", timeout=0.05)
    with SerialDevice(port, tmp_path / "raw.bin") as dev:
        port.write(wire)
        items = _drain(dev, until=lambda it: isinstance(it, DataBlock)
                       and it.index0 == (len(frames) - 1) * 32)
        assert (tmp_path / "raw.bin").read_bytes() == wire  # every byte kept, in order
    cap = HitCapture(INFO, SET)
    cap.arm(0)
    recs = [r for it in items for r in cap.push(it)]
    verdicts = [check_hit(r, SET, FS, cap.n_pre) for r in recs]
    assert [v.reason for v in verdicts] == [None, "data lost", "data lost", "data lost", None]
    assert all("frame(s) lost" in v.detail for v in verdicts[1:4])
    gaps = [g for g in items if isinstance(g, Gap)]
    assert [(g.start, g.stop) for g in gaps] == [(k * 32, k * 32 + 32) for k in (k2, k3, k4)]


def test_csv_line_mode_over_loop():
    codes = _hits([0.3, 1.6], 2.8)
    lines = [f"{a},{b}\n".encode() for a, b in codes]
    lines[int(1.9 * FS)] = b"12,3x4\n"  # a corrupted line inside hit 2
    port = serial.serial_for_url("loop://", timeout=0.05)
    with SerialDevice(port, csv_info=INFO) as dev:
        port.write(b"# any microcontroller\n" + b"".join(lines))
        items = _drain(dev, until=lambda it: isinstance(it, DataBlock)
                       and it.index0 + len(it.codes) >= len(codes))
    cap = HitCapture(INFO, SET)
    cap.arm(0)
    recs = [r for it in items for r in cap.push(it)]
    assert [check_hit(r, SET, FS, cap.n_pre).reason for r in recs] == [None, "data lost"]


def test_device_stops_mid_hit_is_a_reasoned_rejection_and_a_clean_error():
    codes = _hits([0.3], 0.8)  # the record needs 1 s; the device dies at 0.8 s
    port = serial.serial_for_url("loop://", timeout=0.05)
    ack = p.encode_frame(p.ACK, 0, 0, p.encode_ack(1, p.POINT, p.ACK_OK, 2))
    with SerialDevice(port, silence_s=0.5) as dev:
        dev.info = INFO
        port.write(ack + b"".join(_frames(codes)))
        cap, log = HitCapture(INFO, SET), []
        t0 = time.monotonic()
        with pytest.raises(DeviceError, match="stopped sending"):
            acquire_point(dev, cap, 2, 1, SET, log, "point 1/1", lambda m: None)
        assert time.monotonic() - t0 < 3.0
    assert log == [HitLog(2, 1, False, "device stopped mid-hit",
                          "stream ended before the record was complete", -1, 0.0)]


def _box(faults=(), speed=0.0, **kw):
    model = uniform_beam_modes(0.86, 0.9, 175.0, np.linspace(0.05, 0.8, 4))
    return VirtualBox(BoxConfig(model, 3, default_info(8192.0), faults, speed=speed,
                                tap_interval_s=1.6, **kw))


class _Running:
    """A virtual box served by a thread until the test ends."""

    def __init__(self, box, delay_s=0.0):
        self.box, self.stop = box, threading.Event()
        self.thread = threading.Thread(target=self._run, args=(delay_s,), daemon=True)
        self.thread.start()

    def _run(self, delay_s):
        time.sleep(delay_s)
        self.box.serve(lambda b: self.stop.is_set())

    def close(self, unplug=True):
        self.stop.set()
        self.thread.join(2.0)
        if unplug:
            self.box.unplug()


def test_pty_handshake_session_and_lossless_stop(tmp_path):
    run = _Running(_box())
    try:
        with SerialDevice(open_port(run.box.device_path), tmp_path / "raw.bin") as dev:
            info = dev.handshake(sample_rate_hz=8192.0, samples_per_frame=48)
            assert info.sample_rate_hz == 8192.0 and info.samples_per_frame == 48
            assert info.channels[1].sensitivity_mv_per_unit == 1.0
            cap, log = HitCapture(info, SET), []
            recs = acquire_point(dev, cap, 2, 2, SET, log, "p", lambda m: None)
            assert len(recs) == 2 and [h.accepted for h in log] == [True, True]
            ack = dev.stop()
            rest = _drain(dev, timeout_s=0.5)
        data = [i for i in rest if isinstance(i, DataBlock)]
        assert not [i for i in rest if isinstance(i, Gap)]
        assert data[-1].index0 + len(data[-1].codes) == ack.index  # nothing sent was lost
        starts = np.array([b.index0 for b in data])
        assert np.all(starts[1:] == starts[:-1] + [len(b.codes) for b in data[:-1]])
    finally:
        run.close()


def test_handshake_survives_a_late_boot_and_port_is_exclusive():
    run = _Running(_box(), delay_s=1.3)  # a board still booting after a DTR reset
    try:
        with SerialDevice(open_port(run.box.device_path)) as dev:
            with pytest.raises(DeviceError, match="cannot open"):
                open_port(run.box.device_path)  # exclusive: a second program cannot open it
            assert dev.handshake().name == "virtualbox"
    finally:
        run.close()


def test_unplug_mid_stream_raises_a_clean_error():
    run = _Running(_box())
    with SerialDevice(open_port(run.box.device_path)) as dev:
        dev.handshake()
        dev.request(p.POINT, b"\x01\x00")
        assert _drain(dev, timeout_s=0.3)
        run.close(unplug=True)
        with pytest.raises(DeviceError, match="disconnected|stopped sending"):
            _drain(dev, timeout_s=4.0)


def test_open_of_a_missing_port_names_it():
    with pytest.raises(DeviceError, match="/dev/does-not-exist: cannot open serial port"):
        open_port("/dev/does-not-exist")
