"""A simulated acquisition box on a pseudo-terminal, speaking docs/protocol.md.

It plays the technician too: no tap before the first ``POINT n``; then it taps point n
``tap_delay_s`` later and every ``tap_interval_s`` until the next POINT, the response coming
from rigs.hits (exact modal superposition, 24-bit ADC, sensor sensitivities, noise).
Faults are drawn per tap with probability ``fault_rate``, cycling through ``faults`` (from a
point's place in the session on) so that each one occurs: double (a second, weaker tap
8-20 ms later), overload (a tap hard enough to clip), weak (35 N, below the usual acceptance
level), garbage (random bytes between two frames), drop (a DATA frame never sent), bitflip
(one payload bit flipped), truncate (a frame cut short). Every tap and every wire fault is
logged (``tap_log``: JSON lines ``{"tap", "point", "index", "fault", "peak_n"}`` and
``{"event", "index"}``). ``speed`` is stream time per wall time; 0 streams as fast as the
host reads (the pty blocks the box).

Every random draw comes from a generator keyed to what it is for, never from one stream
consumed in the order things happen: a tap's fault, force and wire fault from ``(seed,
POINT command's ordinal, tap's ordinal at that point)``, a frame's noise from ``(seed, POINT
ordinal, frame's ordinal since that POINT)``. How far the box streams ahead of the host (how
many frames it makes before the host's next command arrives) depends on the machine's load;
with one shared stream it shifted every later draw, so one seed gave another session on
every run: other faults at other points, another set of accepted hits (what made
``tests/test_serial_rig.py``'s every-fault session fail now and then). Now a seed gives the
same taps, faults and noise at every point whatever the timing; only the taps the box makes
after the host has its hits and before its next POINT (their number is the timing's) vary,
and the host does not use them.
"""

from __future__ import annotations

import json
import os
import select
import time
import tty
from dataclasses import dataclass, field
from typing import IO

import numpy as np

from rigs import protocol as p
from rigs.hits import Pulse, hammer_force, response_acceleration
from rigs.modal_model import ModalModel

FAULTS = ("double", "overload", "weak", "garbage", "drop", "bitflip", "truncate")


def default_info(sample_rate_hz: float = 12800.0) -> p.DeviceInfo:
    """Describe the virtual box: hammer 2.25 mV/N (PCB 086C03 class), 1 mV/g, +-5 V 24 bit."""
    return p.DeviceInfo((p.Channel("force", "N", 2.25), p.Channel("acceleration", "g", 1.0)),
                        sample_rate_hz, 24, 5.0, 64, (1, 0, 0), "virtualbox")


@dataclass(frozen=True)
class BoxConfig:
    """The simulated bench: structure, sensors and technician."""

    model: ModalModel
    accel_point: int  # index into the model's points
    info: p.DeviceInfo = field(default_factory=default_info)
    faults: tuple[str, ...] = ()
    fault_rate: float = 0.3
    seed: int = 0
    speed: float = 1.0
    tap_delay_s: float = 0.3
    tap_interval_s: float = 2.6
    peak_force_n: float = 250.0
    pulse_s: float = 0.0012
    noise_v: float = 20e-6
    hit_length_s: float = 3.0
    heartbeat_s: float = 0.5


class VirtualBox:
    """The box's state machine (idle / streaming) on the master side of a pty."""

    def __init__(self, config: BoxConfig, tap_log: IO[str] | None = None) -> None:
        for f in config.faults:
            if f not in FAULTS:
                raise ValueError(f"unknown fault {f!r} (known: {', '.join(FAULTS)})")
        self.cfg = config
        self.info = config.info
        self.master, self._slave = os.openpty()
        tty.setraw(self.master)
        tty.setraw(self._slave)
        os.set_blocking(self.master, False)
        self.device_path = os.ttyname(self._slave)
        self._tap_log = tap_log
        self._dec = p.FrameDecoder()
        self._out = bytearray()
        self._counter = 0
        self._streaming = False
        self._n_sent = 0  # next sample index
        self._t0 = 0.0
        self._point = 1
        self._next_tap: int | None = None
        self._n_taps = 0
        self._ordinal = 0  # POINT commands so far
        self._point_start = 0  # sample index of the latest POINT
        self._taps_here = 0  # taps since the latest POINT
        self._faults_here = 0  # faults among them
        self._future = np.zeros((0, 2))
        self._fut0 = 0
        self._events: list[tuple] = []  # (sample index, wire fault, the tap's generator)
        self._last_hb = 0.0
        self._overloaded = False
        self.stops = 0

    @property
    def pending_output(self) -> int:
        """Bytes produced but not yet written to the pty."""
        return len(self._out)

    # ------------------------------------------------------------ framing
    def _frame(self, mtype: int, index: int, payload: bytes, flags: int = 0) -> bytes:
        b = p.encode_frame(mtype, self._counter, index, payload, flags)
        self._counter = (self._counter + 1) & 0xFFFFFFFF
        return b

    def _ack(self, cmd: p.Frame, result: int, arg: int = 0) -> None:
        self._out += self._frame(p.ACK, self._n_sent,
                                 p.encode_ack(cmd.counter, cmd.payload[0], result, arg))

    def _command(self, cmd: p.Frame) -> None:
        if cmd.type != p.COMMAND or not cmd.payload:
            return
        op, args = cmd.payload[0], cmd.payload[1:]
        if op == p.GET_INFO:
            self._out += self._frame(p.INFO, self._n_sent, p.encode_info(self.info))
            self._ack(cmd, p.ACK_OK)
        elif op == p.CONFIGURE:
            if self._streaming:
                return self._ack(cmd, p.ACK_BAD_STATE)
            try:
                rate, n_ch, bits, spf = p.decode_configure(args)
            except ValueError:
                return self._ack(cmd, p.ACK_BAD_ARGUMENT)
            width = 2 if bits == 16 else 3
            if (n_ch != self.info.n_channels or bits != self.info.bits or spf < 1
                    or spf * n_ch * width > p.MAX_PAYLOAD or not 1000 <= rate <= 200_000):
                return self._ack(cmd, p.ACK_BAD_ARGUMENT)
            self.info = p.DeviceInfo(self.info.channels, rate, bits, self.info.adc_full_scale_v,
                                     spf, self.info.firmware, self.info.name)
            self._ack(cmd, p.ACK_OK)
        elif op == p.START:
            self._streaming, self._n_sent, self._t0 = True, 0, time.monotonic()
            self._future, self._fut0, self._events = np.zeros((0, 2)), 0, []
            self._next_tap = None  # the technician waits for the host to name a point
            self._ack(cmd, p.ACK_OK)
        elif op == p.STOP:
            self._streaming = False
            self.stops += 1
            self._ack(cmd, p.ACK_OK)  # queued after every frame already produced
        elif op == p.POINT and len(args) == 2:
            self._point = int.from_bytes(args, "little")
            if not 1 <= self._point <= self.cfg.model.x_m.size:
                return self._ack(cmd, p.ACK_BAD_ARGUMENT, self._point)
            self._next_tap = self._n_sent + int(self.cfg.tap_delay_s * self.info.sample_rate_hz)
            self._ordinal += 1
            self._point_start, self._taps_here, self._faults_here = self._n_sent, 0, 0
            self._ack(cmd, p.ACK_OK, self._point)
        elif op == p.PING:
            self._ack(cmd, p.ACK_OK)
        else:
            self._ack(cmd, p.ACK_UNSUPPORTED)

    # ------------------------------------------------------------ technician
    def _keyed_rng(self, purpose: int, ordinal: int) -> np.random.Generator:
        """Return the generator of one draw: (seed, purpose, POINT ordinal, ``ordinal``)."""
        return np.random.default_rng([self.cfg.seed, purpose, self._ordinal, ordinal])

    def _tap(self, index: int) -> None:
        cfg, fs = self.cfg, self.info.sample_rate_hz
        self._n_taps += 1
        rng = self._keyed_rng(1, self._taps_here)
        self._taps_here += 1
        fault = None
        if cfg.faults and rng.random() < cfg.fault_rate:
            fault = cfg.faults[(self._ordinal - 1 + self._faults_here) % len(cfg.faults)]
            self._faults_here += 1
        peak = cfg.peak_force_n * rng.uniform(0.8, 1.2)
        if fault == "overload":
            fs_force = self.info.adc_full_scale_v / (self.info.channels[0]
                                                     .sensitivity_mv_per_unit * 1e-3)
            peak = 1.3 * fs_force
        elif fault == "weak":
            peak = 35.0
        pulses = [Pulse(0.0, cfg.pulse_s, peak)]
        if fault == "double":
            pulses.append(Pulse(rng.uniform(0.008, 0.02), cfg.pulse_s,
                                peak * rng.uniform(0.3, 0.6)))
        n = int(cfg.hit_length_s * fs)
        t = np.arange(n) / fs
        sig = np.column_stack([
            hammer_force(t, pulses),
            response_acceleration(cfg.model, cfg.accel_point, self._point - 1, t, pulses,
                                  fmax_hz=0.45 * fs),
        ])
        self._add_future(index, sig)
        if fault in ("garbage", "drop", "bitflip", "truncate"):
            at = index + int(rng.uniform(0.05, 1.0) * fs)
            self._events.append((at, fault, rng))
        self._log({"tap": self._n_taps, "point": self._point, "index": index, "fault": fault,
                   "peak_n": round(peak, 2)})

    def _log(self, entry: dict) -> None:
        if self._tap_log is not None:
            self._tap_log.write(json.dumps(entry) + "\n")
            self._tap_log.flush()

    def _add_future(self, index: int, sig: np.ndarray) -> None:
        off = index - self._fut0
        need = off + sig.shape[0]
        if need > self._future.shape[0]:
            self._future = np.vstack([self._future, np.zeros((need - self._future.shape[0], 2))])
        self._future[off:need] += sig

    def _take(self, n: int) -> np.ndarray:
        """Signal (SI) of the next n samples; consumes them from the future buffer."""
        off = self._n_sent - self._fut0
        out = np.zeros((n, 2))
        avail = max(0, min(n, self._future.shape[0] - off))
        out[:avail] = self._future[off:off + avail]
        if off + n > 65536:
            self._future = self._future[off + n:]
            self._fut0 = self._n_sent + n
        return out

    # ------------------------------------------------------------ streaming
    def _produce_frame(self) -> None:
        info, spf = self.info, self.info.samples_per_frame
        i0 = self._n_sent
        if self._next_tap is not None and self._next_tap < i0 + spf:
            self._tap(self._next_tap)
            self._next_tap += int(self.cfg.tap_interval_s * info.sample_rate_hz)
        si = self._take(spf)
        volts_per_code = info.adc_full_scale_v / 2 ** (info.bits - 1)
        scale = info.scale_si()
        noise = self._keyed_rng(3, (i0 - self._point_start) // spf)
        codes = np.rint(si / scale + noise.normal(0, self.cfg.noise_v / volts_per_code,
                                                  si.shape))
        fsc = info.full_scale_code
        over = bool(np.any(np.abs(codes) >= fsc))
        codes = np.clip(codes, -fsc, fsc).astype(np.int32)
        if over and not self._overloaded:
            mask = int(np.any(np.abs(codes) >= fsc, axis=0) @ (1 << np.arange(2)))
            self._out += self._frame(p.STATUS, i0, p.encode_status(p.STATUS_OVERLOAD, mask))
        self._overloaded = over
        frame = self._frame(p.DATA, i0, p.encode_samples(codes, info.bits),
                            p.data_flags(info.n_channels, info.bits, overload=over))
        self._n_sent += spf
        due = [e for e in self._events if e[0] < self._n_sent]
        self._events = [e for e in self._events if e[0] >= self._n_sent]
        for _, fault, rng in due:  # (the generator of the tap that caused it)
            self._log({"event": fault, "index": i0})
            if fault == "garbage":
                self._out += rng.integers(0, 256, int(rng.integers(5, 200)),
                                          dtype=np.uint8).tobytes()
            elif fault == "drop":
                frame = b""
            elif fault == "bitflip":
                b = bytearray(frame)
                k = int(rng.integers(p.HEADER_LEN, len(b) - 4))
                b[k] ^= 1 << int(rng.integers(0, 8))
                frame = bytes(b)
            elif fault == "truncate":
                frame = frame[:int(rng.integers(p.HEADER_LEN, len(frame) - 1))]
        self._out += frame

    def _samples_allowed(self) -> float:
        if self.cfg.speed <= 0:
            return np.inf
        return (time.monotonic() - self._t0) * self.info.sample_rate_hz * self.cfg.speed

    def step(self, timeout_s: float = 0.01) -> bool:
        """One pass of the event loop; False once the host side is gone for good."""
        want_write = bool(self._out)
        try:
            r, w, _ = select.select([self.master], [self.master] if want_write else [], [],
                                    timeout_s)
        except (OSError, ValueError):
            return False
        if r:
            try:
                data = os.read(self.master, 4096)
            except BlockingIOError:
                data = b""
            except OSError:
                return False
            for frame in self._dec.feed(data):
                self._command(frame)
        if w and self._out:
            try:
                n = os.write(self.master, bytes(self._out[:4096]))
            except BlockingIOError:
                n = 0
            except OSError:
                return False
            del self._out[:n]
        now = time.monotonic()
        if self._streaming:
            budget = 32
            while (budget and len(self._out) < 16384
                   and self._n_sent + self.info.samples_per_frame <= self._samples_allowed()):
                self._produce_frame()
                budget -= 1
        elif now - self._last_hb >= self.cfg.heartbeat_s:
            self._out += self._frame(p.HEARTBEAT, self._n_sent,
                                     p.encode_heartbeat(int(now * 1000), False))
            self._last_hb = now
        return True

    def serve(self, should_stop=lambda box: False) -> None:
        """Run until ``should_stop(box)`` is true or the pty fails."""
        while not should_stop(self) and self.step():
            pass

    def unplug(self) -> None:
        """Close both ends of the pty, as if the USB cable were pulled."""
        for fd in (self.master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        self.master = self._slave = -1

    def close(self) -> None:
        """Unplug the box (close the pseudo-terminal)."""
        self.unplug()
