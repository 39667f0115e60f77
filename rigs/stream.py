"""From decoded frames to a checked sample stream: data blocks, gaps, status, acks.

Loss is detected exactly, never guessed: every device frame carries a 32-bit counter that
increments by one per frame sent (all device message types), and every DATA frame carries the
64-bit index of its first sample. A counter jump means frames were lost (whatever their type);
a sample-index jump means samples were lost. Both become a :class:`Gap` at the sample index
where the stream stopped being trustworthy, so a hit whose record touches it is rejected.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigs import protocol as p


@dataclass(frozen=True)
class DataBlock:
    """Consecutive samples ``index0 .. index0 + len(codes) - 1`` as (n, ch) int32 codes."""

    index0: int
    codes: np.ndarray
    overload: bool = False
    fault: bool = False


@dataclass(frozen=True)
class Gap:
    """Samples ``start .. stop - 1`` are missing or unverifiable.

    stop == start: a lost non-data frame between samples start - 1 and start.
    """

    start: int
    stop: int
    reason: str


Item = DataBlock | Gap | p.Status | p.Ack | p.DeviceInfo


class StreamTracker:
    """Turn frames into items, checking frame counters and sample indices.

    Attributes
    ----------
    expected_index : int or None
        Index of the next sample expected (None before streaming starts).
    """

    def __init__(self) -> None:
        self._counter: int | None = None
        self.expected_index: int | None = None
        self.frames_lost = 0
        self.samples_lost = 0

    def push(self, frame: p.Frame) -> list[Item]:
        """Take one decoded frame; return the items it yields (gaps before data)."""
        if frame.type not in p.DEVICE_TYPES:
            return []  # host->device frames (e.g. a loop-back port) carry the host's counter
        out: list[Item] = []
        if self._counter is not None:
            jump = (frame.counter - self._counter - 1) & 0xFFFFFFFF
            if jump:
                self.frames_lost += jump
                at = self.expected_index if self.expected_index is not None else 0
                stop = at
                if frame.type == p.DATA and frame.first_index > at:
                    stop = frame.first_index
                out.append(Gap(at, stop, f"{jump} frame(s) lost (frame counter "
                                         f"{(self._counter + 1) & 0xFFFFFFFF} -> {frame.counter})"))
        self._counter = frame.counter
        if frame.type == p.DATA:
            n_ch, bits = p.decode_data_format(frame.flags)
            try:
                codes = p.decode_samples(frame.payload, n_ch, bits)
            except ValueError as exc:
                out.append(Gap(frame.first_index, frame.first_index, f"bad DATA frame: {exc}"))
                return out
            exp = self.expected_index
            if exp is not None and frame.first_index != exp:
                if frame.first_index > exp:
                    self.samples_lost += frame.first_index - exp
                    if not (out and isinstance(out[-1], Gap) and out[-1].stop == frame.first_index):
                        out.append(Gap(exp, frame.first_index,
                                       f"{frame.first_index - exp} sample(s) lost "
                                       f"(sample index {exp} -> {frame.first_index})"))
                else:
                    out.append(Gap(frame.first_index, exp, f"sample index went back from {exp} "
                                                           f"to {frame.first_index}"))
            self.expected_index = frame.first_index + codes.shape[0]
            out.append(DataBlock(frame.first_index, codes, bool(frame.flags & p.FLAG_OVERLOAD),
                                 bool(frame.flags & p.FLAG_FAULT)))
        elif frame.type == p.ACK:
            ack = p.decode_ack(frame)
            if ack.opcode == p.START and ack.result == p.ACK_OK:
                self.expected_index = ack.index
            out.append(ack)
        elif frame.type == p.STATUS:
            out.append(p.decode_status(frame))
        elif frame.type == p.INFO:
            out.append(p.decode_info(frame.payload))
        return out


class CsvTracker:
    """Line-mode counterpart: sample indices are line numbers; a bad line is a 1-sample gap."""

    def __init__(self, info: p.DeviceInfo) -> None:
        self._dec = p.CsvDecoder(info.n_channels)
        self.expected_index = 0

    def feed(self, data: bytes) -> list[Item]:
        """Take received bytes; return data blocks, and 1-sample gaps for bad lines."""
        values, bad = self._dec.feed(data)
        if not values.shape[0]:
            return []
        i0 = self.expected_index
        self.expected_index += values.shape[0]
        codes = np.nan_to_num(values).round().astype(np.int32)
        out: list[Item] = []
        out += [Gap(i0 + int(k), i0 + int(k) + 1, "malformed CSV line")
                for k in np.flatnonzero(bad)]
        out.append(DataBlock(i0, codes))
        return out
