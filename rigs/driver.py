"""Serial driver for the acquisition box (pyserial), and replay of a recorded raw stream.

A reader thread reads the port, writes every byte to the raw stream file first (so a hit is
on disk before it is processed), decodes frames and puts checked items (rigs.stream) into a
bounded queue. When the consumer falls behind, the queue blocks the reader, the OS and USB
buffers fill and the device reports an overrun: loss then shows up as a sample-index gap,
never as silently stitched data. Both :class:`SerialDevice` and :class:`ReplaySource` offer
``next_item(timeout)``, ``request(opcode, args)``, ``info`` and ``flush_raw()``.
"""

from __future__ import annotations

import collections
import os
import queue
import threading
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from rigs import protocol as p
from rigs.stream import CsvTracker, Item, StreamTracker

if TYPE_CHECKING:  # pyserial is imported where a port is opened (a fast ``batlab --help``)
    import serial


class DeviceError(OSError):
    """The device is gone, silent or answering nonsense (one-line message)."""


class EndOfStream(OSError):
    """A recorded stream has no more data."""


@dataclass(frozen=True)
class _Disconnected:
    message: str


def open_port(url: str, baudrate: int = 921600, timeout_s: float = 0.05) -> serial.SerialBase:
    """Open a serial port or pyserial URL without pulsing DTR/RTS, exclusively where possible.

    DTR and RTS are set low before opening so that boards which reset on DTR (Arduino-style
    auto-reset) are not reset by pyserial; the OS may still raise DTR briefly on open, which
    the handshake tolerates by retrying GET_INFO for longer than a boot takes.

    Parameters
    ----------
    url : str
        A device path (``/dev/ttyACM0``) or a pyserial URL (``loop://``, ``socket://...``).
    baudrate : int, optional
        Line speed, baud (ignored by USB CDC devices).
    timeout_s : float, optional
        Read timeout, s.

    Returns
    -------
    serial.SerialBase
        The open port.

    Raises
    ------
    DeviceError
        The port cannot be opened (one line naming it).
    """
    import serial

    kwargs = {"exclusive": True} if os.name == "posix" and "://" not in url else {}
    try:
        port = serial.serial_for_url(url, baudrate=baudrate, timeout=timeout_s,
                                     write_timeout=2.0, do_not_open=True, **kwargs)
        port.dtr = False
        port.rts = False
        port.open()
    except (serial.SerialException, OSError, ValueError) as exc:
        raise DeviceError(f"{url}: cannot open serial port: {exc}") from None
    return port


class SerialDevice:
    """Live acquisition box on an open pyserial port.

    Parameters
    ----------
    port : serial.SerialBase
        open port (see :func:`open_port`; ``serial_for_url("loop://")`` in tests).
    raw_path : str | Path | None, optional
        file receiving every byte read, flushed as it is read; None for none.
    csv_info : p.DeviceInfo | None, optional
        if given, the port speaks the ASCII line mode with this channel layout.
    queue_size : int, optional
        bound of the item queue (items are frames, ~5 ms of samples each).
    silence_s : float, optional
        no byte at all for this long is reported as a dead device.
    """

    def __init__(self, port: serial.SerialBase, raw_path: str | Path | None = None,
                 csv_info: p.DeviceInfo | None = None, queue_size: int = 1024,
                 silence_s: float = 2.0) -> None:
        self.port = port
        self.name = getattr(port, "portstr", None) or str(port.port)
        self.info: p.DeviceInfo | None = csv_info
        self.csv = csv_info is not None
        self.silence_s = silence_s
        self.decoder = p.FrameDecoder()
        self.tracker = StreamTracker()
        self._csv = CsvTracker(csv_info) if csv_info else None
        self._raw = open(raw_path, "wb") if raw_path else None  # noqa: SIM115 (closed in close)
        self._q: queue.Queue = queue.Queue(maxsize=queue_size)
        self._pending: collections.deque = collections.deque()
        self._stop = threading.Event()
        self._last_rx = time.monotonic()
        self._error: str | None = None
        self._cmd_counter = 0
        self._write_lock = threading.Lock()
        self._thread = threading.Thread(target=self._reader, name="batlab-serial", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------ reader thread
    def _put(self, item: object) -> None:
        while not self._stop.is_set():
            try:
                self._q.put(item, timeout=0.1)
                return
            except queue.Full:
                continue

    def _reader(self) -> None:
        while not self._stop.is_set():
            try:
                data = self.port.read(max(1, self.port.in_waiting))
            except (OSError, TypeError, AttributeError) as exc:  # SerialException is an OSError
                if not self._stop.is_set():
                    self._put(_Disconnected(" ".join(str(exc).split()) or type(exc).__name__))
                return
            if not data:
                continue
            self._last_rx = time.monotonic()
            if self._raw:
                self._raw.write(data)
                self._raw.flush()
            try:
                items = self._decode(data)
            except ValueError as exc:  # a CRC-valid frame with a nonsensical payload
                self._put(_Disconnected(f"device sent an invalid frame: {exc}"))
                return
            for it in items:
                self._put(it)

    def _decode(self, data: bytes) -> list[Item]:
        if self._csv is not None:
            return self._csv.feed(data)
        out: list[Item] = []
        for frame in self.decoder.feed(data):
            out += self.tracker.push(frame)
        return out

    # ------------------------------------------------------------ consumer side
    def _get(self, timeout_s: float) -> Item | None:
        if self._error:
            raise DeviceError(self._error)
        try:
            item = self._q.get(timeout=timeout_s)
        except queue.Empty:
            silent = time.monotonic() - self._last_rx
            if silent > self.silence_s:
                self._error = f"{self.name}: device stopped sending (nothing for {silent:.1f} s)"
                raise DeviceError(self._error) from None
            return None
        if isinstance(item, _Disconnected):
            self._error = f"{self.name}: device disconnected ({item.message})"
            raise DeviceError(self._error)
        if isinstance(item, p.DeviceInfo):
            self.info = item
        return item

    def next_item(self, timeout_s: float = 0.2) -> Item | None:
        """Next stream item in order, or None after ``timeout_s`` without one."""
        if self._pending:
            return self._pending.popleft()
        return self._get(timeout_s)

    def send(self, opcode: int, args: bytes = b"") -> int:
        """Write one COMMAND frame; returns its counter."""
        self._cmd_counter += 1
        frame = p.encode_frame(p.COMMAND, self._cmd_counter, 0, p.encode_command(opcode, args))
        try:
            with self._write_lock:
                self.port.write(frame)
                self.port.flush()
        except OSError as exc:  # SerialException included
            raise DeviceError(f"{self.name}: write failed ({exc})") from None
        return self._cmd_counter

    def request(self, opcode: int, args: bytes = b"", timeout_s: float = 1.0,
                retries: int = 3) -> p.Ack | None:
        """Send a command and wait for its ACK.

        Other items are kept, in order, for :meth:`next_item`. None in CSV mode (no
        commands).
        """
        if self.csv:
            return None
        for _ in range(retries):
            counter = self.send(opcode, args)
            deadline = time.monotonic() + timeout_s
            while time.monotonic() < deadline:
                item = self._get(min(0.1, max(deadline - time.monotonic(), 0.001)))
                if isinstance(item, p.Ack) and item.command_counter == counter:
                    return item
                if item is not None and not isinstance(item, (p.Ack, p.DeviceInfo)):
                    self._pending.append(item)
        raise DeviceError(f"{self.name}: no answer to command 0x{opcode:02x} after {retries} "
                          f"tries")

    def handshake(self, sample_rate_hz: float | None = None, samples_per_frame: int | None = None,
                  timeout_s: float = 1.0, retries: int = 4) -> p.DeviceInfo:
        """Run GET_INFO, CONFIGURE, START (docs/protocol.md, 'Host handshake').

        A device still streaming (its last host was killed) answers CONFIGURE with BAD_STATE:
        it is sent STOP and configured again. Returns the device's info.
        """
        if self.csv:
            return self.info
        ack = self.request(p.GET_INFO, timeout_s=timeout_s, retries=retries)
        if self.info is None or ack.result != p.ACK_OK:
            raise DeviceError(f"{self.name}: device did not describe itself (no INFO)")
        info = replace(self.info, sample_rate_hz=sample_rate_hz or self.info.sample_rate_hz,
                       samples_per_frame=samples_per_frame or self.info.samples_per_frame)
        config = p.encode_configure(info.sample_rate_hz, info.n_channels, info.bits,
                                    info.samples_per_frame)[1:]
        ack = self.request(p.CONFIGURE, config)
        if ack.result == p.ACK_BAD_STATE:  # still streaming for a host that died: stop it
            self.request(p.STOP)
            ack = self.request(p.CONFIGURE, config)
        if ack.result != p.ACK_OK:
            raise DeviceError(f"{self.name}: device refused configuration {info.sample_rate_hz} "
                              f"Hz x {info.samples_per_frame} samples/frame (code {ack.result})")
        self.info = info
        ack = self.request(p.START)
        if ack.result != p.ACK_OK:
            raise DeviceError(f"{self.name}: device refused START (code {ack.result})")
        return info

    def flush_raw(self) -> None:
        """Make sure every byte read so far is on disk."""
        if self._raw:
            self._raw.flush()
            os.fsync(self._raw.fileno())

    def stop(self) -> p.Ack | None:
        """Stop streaming.

        The device sends its last frames before the ACK (whose index is the next sample
        index), so nothing sent is lost: those frames stay readable through
        :meth:`next_item`.
        """
        if self.csv or self._error is not None:
            return None
        return self.request(p.STOP)

    def close(self) -> None:
        """Stop the reader thread, close the port and the raw file."""
        self._stop.set()
        try:
            self.port.cancel_read()
        except (AttributeError, NotImplementedError, OSError):
            pass
        self._thread.join(timeout=2.0)
        try:
            self.port.close()
        except OSError:
            pass
        if self._raw:
            self._raw.close()
            self._raw = None

    def __enter__(self) -> SerialDevice:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class ReplaySource:
    """A recorded raw stream (as written by :class:`SerialDevice`), played back.

    The stream goes through the same decoder and tracker; commands are not sent, their
    recorded ACKs are looked up instead.
    """

    def __init__(self, path: str | Path, csv_info: p.DeviceInfo | None = None,
                 chunk: int = 65536) -> None:
        self.path = Path(path)
        try:
            self._f = open(self.path, "rb")  # noqa: SIM115 (closed in close)
        except OSError as exc:
            raise OSError(f"{path}: cannot read recorded stream ({exc.strerror})") from None
        self.name = str(path)
        self.info: p.DeviceInfo | None = csv_info
        self.csv = csv_info is not None
        self.decoder = p.FrameDecoder()
        self.tracker = StreamTracker()
        self._csv = CsvTracker(csv_info) if csv_info else None
        self._chunk = chunk
        self._items: collections.deque = collections.deque()

    def _fill(self) -> None:
        while not self._items:
            data = self._f.read(self._chunk)
            if not data:
                raise EndOfStream(f"{self.path}: recorded stream ended")
            if self._csv is not None:
                self._items.extend(self._csv.feed(data))
            else:
                for frame in self.decoder.feed(data):
                    self._items.extend(self.tracker.push(frame))

    def next_item(self, timeout_s: float = 0.0) -> Item:
        """Return the next recorded item; EndOfStream when there is none (no waiting)."""
        self._fill()
        item = self._items.popleft()
        if isinstance(item, p.DeviceInfo):
            self.info = item
        return item

    def request(self, opcode: int, args: bytes = b"", **_: object) -> p.Ack | None:
        """Find the next recorded ACK of this opcode (items before it stay queued in order)."""
        if self.csv:
            return None
        held = []
        try:
            while True:
                item = self.next_item()
                if isinstance(item, p.Ack) and item.opcode == opcode:
                    return item
                if not isinstance(item, p.Ack):
                    held.append(item)
        finally:
            self._items.extendleft(reversed(held))

    def handshake(self, *_: object, **__: object) -> p.DeviceInfo:
        """Replay the handshake: the recorded START and the device info."""
        if not self.csv:
            self.request(p.START)
        if self.info is None:
            raise ValueError(f"{self.path}: recorded stream has no INFO frame before START")
        return self.info

    def flush_raw(self) -> None:
        """Do nothing: a replay writes no raw stream."""

    def stop(self) -> None:
        """Do nothing: a recording cannot be stopped."""

    def close(self) -> None:
        """Close the recorded file."""
        self._f.close()

    def __enter__(self) -> ReplaySource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
