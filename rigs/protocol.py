"""The batlab acquisition-box wire protocol: frame layout, CRCs, payload codecs, decoder.

Specification: docs/protocol.md (this module is its reference implementation). A frame is

    sync 0xA5 0x5A | type u8 | flags u8 | counter u32 | first_index u64 | length u16 |
    header CRC-16/CCITT-FALSE u16 | payload (length bytes) | CRC-32 (IEEE) u32

little-endian throughout. CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no
final xor) covers bytes 0..17; CRC-32 (zlib/IEEE 802.3, poly 0x04C11DB7 reflected) covers
bytes 0..19+length. Check values for b"123456789": 0x29B1 and 0xCBF43926.
"""

from __future__ import annotations

import binascii
import io
import struct
import zlib
from dataclasses import dataclass

import numpy as np

SYNC = b"\xa5\x5a"
PROTOCOL_VERSION = 1
HEADER = struct.Struct("<2sBBIQH")  # sync, type, flags, counter, first_index, length
HEADER_LEN = HEADER.size + 2  # + header CRC-16 = 20
TRAILER_LEN = 4
MAX_PAYLOAD = 4096

# message types
INFO, DATA, STATUS, HEARTBEAT, COMMAND, ACK = 0x01, 0x02, 0x03, 0x04, 0x10, 0x11
DEVICE_TYPES = frozenset({INFO, DATA, STATUS, HEARTBEAT, ACK})

# command opcodes (first payload byte of a COMMAND frame)
GET_INFO, CONFIGURE, START, STOP, POINT, PING = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
# ACK result codes
ACK_OK, ACK_UNSUPPORTED, ACK_BAD_ARGUMENT, ACK_BAD_STATE = 0, 1, 2, 3

# DATA frame flag bits: bits 0-2 n_channels - 1, bit 3 24-bit samples, bit 4 overload,
# bit 5 sensor fault
FLAG_24BIT, FLAG_OVERLOAD, FLAG_FAULT = 0x08, 0x10, 0x20
# STATUS bits
STATUS_OVERLOAD, STATUS_OVERRUN, STATUS_FAULT = 0x01, 0x02, 0x04

CHANNEL_KINDS = ("force", "acceleration", "voltage")
UNIT_TO_SI = {"N": 1.0, "g": 9.80665, "m/s^2": 1.0, "V": 1.0}

_INFO_HEAD = struct.Struct("<BBBBBBHdf12s")
_INFO_CHANNEL = struct.Struct("<B7sff")
_CONFIGURE = struct.Struct("<dBBH")
_ACK = struct.Struct("<IBBH")
_STATUS = struct.Struct("<BBBBI")
_HEARTBEAT = struct.Struct("<IB3x")


def crc16_ccitt(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, MSB first; crc16(b"123456789") = 0x29B1."""
    return binascii.crc_hqx(data, crc)


def crc32(data: bytes) -> int:
    """CRC-32/IEEE (zlib): crc32(b"123456789") = 0xCBF43926."""
    return zlib.crc32(data) & 0xFFFFFFFF


@dataclass(frozen=True)
class Frame:
    """One decoded frame (payload still in bytes)."""

    type: int
    flags: int
    counter: int
    first_index: int
    payload: bytes


def encode_frame(
    msg_type: int, counter: int, first_index: int, payload: bytes = b"", flags: int = 0
) -> bytes:
    """Encode one frame to bytes (see module docstring)."""
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}")
    head = HEADER.pack(SYNC, msg_type, flags, counter & 0xFFFFFFFF, first_index, len(payload))
    head += struct.pack("<H", crc16_ccitt(head))
    body = head + payload
    return body + struct.pack("<I", crc32(body))


# ---------------------------------------------------------------- payload codecs


@dataclass(frozen=True)
class Channel:
    """One input channel: kind ('force', 'acceleration', 'voltage'), unit and sensitivity."""

    kind: str
    unit: str
    sensitivity_mv_per_unit: float


@dataclass(frozen=True)
class DeviceInfo:
    """What the box says about itself (INFO message) and how to turn codes into SI units."""

    channels: tuple[Channel, ...]
    sample_rate_hz: float
    bits: int
    adc_full_scale_v: float
    samples_per_frame: int = 64
    firmware: tuple[int, int, int] = (1, 0, 0)
    name: str = "batbox"
    protocol_version: int = PROTOCOL_VERSION

    @property
    def n_channels(self) -> int:
        """Number of channels."""
        return len(self.channels)

    @property
    def full_scale_code(self) -> int:
        """Largest positive code, 2**(bits-1) - 1."""
        return 2 ** (self.bits - 1) - 1

    def scale_si(self) -> np.ndarray:
        """(n_channels,) SI units per ADC code: V/code / (V/unit) * SI/unit."""
        v_per_code = self.adc_full_scale_v / 2 ** (self.bits - 1)
        return np.array(
            [v_per_code / (c.sensitivity_mv_per_unit * 1e-3) * UNIT_TO_SI[c.unit]
             for c in self.channels]
        )

    def channel_index(self, kind: str) -> int:
        """Index of the first channel of the given kind."""
        for i, c in enumerate(self.channels):
            if c.kind == kind:
                return i
        raise ValueError(f"device has no {kind} channel")


def device_info_from_dict(d: dict, where: str = "device description") -> DeviceInfo:
    """Build a DeviceInfo from a JSON-style dict (CSV line mode has no INFO message).

    The dict: {"sample_rate_hz", "bits", "adc_full_scale_v", "channels": [{"kind", "unit",
    "sensitivity_mv_per_unit"}, ...]}.
    """
    try:
        chans = tuple(Channel(str(c["kind"]), str(c["unit"]), float(c["sensitivity_mv_per_unit"]))
                      for c in d["channels"])
        info = DeviceInfo(chans, float(d["sample_rate_hz"]), int(d.get("bits", 24)),
                          float(d["adc_full_scale_v"]), name=str(d.get("name", "csv")))
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{where}: bad channel description ({exc!r})") from None
    if any(c.kind not in CHANNEL_KINDS or c.unit not in UNIT_TO_SI for c in chans):
        raise ValueError(f"{where}: channel kinds must be {CHANNEL_KINDS}, "
                         f"units {list(UNIT_TO_SI)}")
    return info


def encode_info(info: DeviceInfo) -> bytes:
    """INFO payload: 32-byte head then 16 bytes per channel (docs/protocol.md)."""
    out = _INFO_HEAD.pack(info.protocol_version, *info.firmware, info.n_channels, info.bits,
                          info.samples_per_frame, info.sample_rate_hz, info.adc_full_scale_v,
                          info.name.encode("ascii")[:12])
    for c in info.channels:
        out += _INFO_CHANNEL.pack(CHANNEL_KINDS.index(c.kind), c.unit.encode("ascii")[:7],
                                  c.sensitivity_mv_per_unit, 0.0)
    return out


def decode_info(payload: bytes) -> DeviceInfo:
    """Inverse of :func:`encode_info`; ValueError on a malformed payload."""
    if len(payload) < _INFO_HEAD.size:
        raise ValueError(f"INFO payload of {len(payload)} bytes is too short")
    ver, fa, fb, fc, n, bits, spf, rate, fs_v, name = _INFO_HEAD.unpack_from(payload)
    if len(payload) != _INFO_HEAD.size + n * _INFO_CHANNEL.size or bits not in (16, 24):
        raise ValueError(f"INFO payload inconsistent ({n} channels, {bits} bits)")
    chans = []
    for i in range(n):
        kind, unit, sens, _ = _INFO_CHANNEL.unpack_from(payload, _INFO_HEAD.size + 16 * i)
        if kind >= len(CHANNEL_KINDS):
            raise ValueError(f"INFO channel {i} has unknown kind {kind}")
        unit_s = unit.rstrip(b"\0").decode("ascii")
        if unit_s not in UNIT_TO_SI:
            raise ValueError(f"INFO channel {i} has unknown unit {unit_s!r}")
        chans.append(Channel(CHANNEL_KINDS[kind], unit_s, float(sens)))
    return DeviceInfo(tuple(chans), float(rate), bits, float(fs_v), spf, (fa, fb, fc),
                      name.rstrip(b"\0").decode("ascii", "replace"), ver)


def data_flags(n_channels: int, bits: int, overload: bool = False, fault: bool = False) -> int:
    """Encode the flags byte of a DATA frame (channel count, sample width)."""
    if not 1 <= n_channels <= 8 or bits not in (16, 24):
        raise ValueError(f"unsupported sample format: {n_channels} channels, {bits} bits")
    return ((n_channels - 1) | (FLAG_24BIT if bits == 24 else 0)
            | (FLAG_OVERLOAD if overload else 0) | (FLAG_FAULT if fault else 0))


def encode_samples(codes: np.ndarray, bits: int) -> bytes:
    """(n, ch) integer codes -> interleaved little-endian two's complement, 2 or 3 bytes each."""
    c = np.ascontiguousarray(codes, dtype="<i4")
    if bits == 16:
        return c.astype("<i2").tobytes()
    return c.view(np.uint8).reshape(-1, 4)[:, :3].tobytes()


def decode_samples(payload: bytes, n_channels: int, bits: int) -> np.ndarray:
    """Interleaved payload -> (n, n_channels) int32 codes (24-bit sign-extended, vectorised)."""
    width = 2 if bits == 16 else 3
    if len(payload) % (width * n_channels):
        raise ValueError(f"DATA payload of {len(payload)} bytes is not whole samples")
    if bits == 16:
        return np.frombuffer(payload, "<i2").astype(np.int32).reshape(-1, n_channels)
    b = np.frombuffer(payload, np.uint8).reshape(-1, 3).astype(np.int32)
    v = b[:, 0] | (b[:, 1] << 8) | (b[:, 2] << 16)
    return ((v ^ 0x800000) - 0x800000).reshape(-1, n_channels)


def decode_data_format(flags: int) -> tuple[int, int]:
    """(n_channels, bits) from a DATA frame's flags."""
    return (flags & 0x07) + 1, 24 if flags & FLAG_24BIT else 16


def encode_command(opcode: int, args: bytes = b"") -> bytes:
    """Encode a COMMAND payload: the opcode byte, then its arguments."""
    return bytes([opcode]) + args


def encode_configure(sample_rate_hz: float, n_channels: int, bits: int, samples_per_frame: int
                     ) -> bytes:
    """Encode a CONFIGURE command with its sampling arguments."""
    return encode_command(CONFIGURE, _CONFIGURE.pack(sample_rate_hz, n_channels, bits,
                                                     samples_per_frame))


def decode_configure(args: bytes) -> tuple[float, int, int, int]:
    """Decode CONFIGURE arguments: (sample rate Hz, channels, bits, samples per frame)."""
    if len(args) != _CONFIGURE.size:
        raise ValueError("CONFIGURE arguments have the wrong length")
    return _CONFIGURE.unpack(args)


@dataclass(frozen=True)
class Ack:
    """Device's answer to a command; ``index`` is the next sample index when it was executed."""

    index: int
    command_counter: int
    opcode: int
    result: int
    arg: int


def encode_ack(command_counter: int, opcode: int, result: int, arg: int = 0) -> bytes:
    """Encode an ACK payload answering command ``command_counter``."""
    return _ACK.pack(command_counter & 0xFFFFFFFF, opcode, result, arg & 0xFFFF)


def decode_ack(frame: Frame) -> Ack:
    """Decode an ACK frame; ValueError when its payload has the wrong length."""
    if len(frame.payload) != _ACK.size:
        raise ValueError("ACK payload has the wrong length")
    return Ack(frame.first_index, *_ACK.unpack(frame.payload))


@dataclass(frozen=True)
class Status:
    """Device status report at sample ``index`` (STATUS message)."""

    index: int
    bits: int
    overload_mask: int
    fault_mask: int
    lost_samples: int

    @property
    def overload(self) -> bool:
        """Whether a channel is at full scale."""
        return bool(self.bits & STATUS_OVERLOAD)

    @property
    def overrun(self) -> bool:
        """Whether the device dropped samples (its buffer overran)."""
        return bool(self.bits & STATUS_OVERRUN)

    @property
    def fault(self) -> bool:
        """Whether the device reports a channel fault."""
        return bool(self.bits & STATUS_FAULT)


def encode_status(bits: int, overload_mask: int = 0, fault_mask: int = 0, lost: int = 0) -> bytes:
    """Encode a STATUS payload: status bits, per-channel masks, samples lost."""
    return _STATUS.pack(bits, overload_mask, fault_mask, 0, lost)


def decode_status(frame: Frame) -> Status:
    """Decode a STATUS frame; ValueError when its payload has the wrong length."""
    if len(frame.payload) != _STATUS.size:
        raise ValueError("STATUS payload has the wrong length")
    bits, om, fm, _, lost = _STATUS.unpack(frame.payload)
    return Status(frame.first_index, bits, om, fm, lost)


def encode_heartbeat(uptime_ms: int, streaming: bool) -> bytes:
    """Encode a HEARTBEAT payload: uptime, ms, and whether the device streams."""
    return _HEARTBEAT.pack(uptime_ms & 0xFFFFFFFF, int(streaming))


# ---------------------------------------------------------------- byte-stream decoders


@dataclass
class DecoderStats:
    """Counts of what the decoder threw away."""

    frames: int = 0
    garbage_bytes: int = 0
    header_errors: int = 0
    crc_errors: int = 0


class FrameDecoder:
    """Incremental frame decoder with resynchronisation.

    Bytes are searched for the sync word; a candidate whose header CRC or frame CRC fails is
    abandoned and the search restarts one byte after its sync word, so garbage, bit flips and
    truncated frames cost only the frames they touch. Lost frames are not guessed here: the
    stream tracker detects them from the frame counter and sample index.
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        self.stats = DecoderStats()

    @property
    def pending(self) -> int:
        """Bytes held while waiting for the rest of a frame."""
        return len(self._buf)

    def feed(self, data: bytes) -> list[Frame]:
        """Take received bytes; return the complete frames with a valid CRC, in order."""
        buf = self._buf
        buf += data
        out: list[Frame] = []
        pos, n = 0, len(buf)
        while True:
            i = buf.find(SYNC, pos)
            if i < 0:
                keep = n - 1 if n and buf[-1] == SYNC[0] else n
                self.stats.garbage_bytes += max(keep - pos, 0)
                pos = max(keep, pos)
                break
            self.stats.garbage_bytes += i - pos
            pos = i
            if n - i < HEADER_LEN:
                break
            _, mtype, flags, counter, index, length = HEADER.unpack_from(buf, i)
            (hcrc,) = struct.unpack_from("<H", buf, i + HEADER.size)
            if hcrc != crc16_ccitt(bytes(buf[i:i + HEADER.size])) or length > MAX_PAYLOAD:
                self.stats.header_errors += 1
                self.stats.garbage_bytes += 1
                pos = i + 1
                continue
            end = i + HEADER_LEN + length + TRAILER_LEN
            if n < end:
                break
            body = bytes(buf[i:end - TRAILER_LEN])
            (fcrc,) = struct.unpack_from("<I", buf, end - TRAILER_LEN)
            if fcrc != crc32(body):
                self.stats.crc_errors += 1
                self.stats.garbage_bytes += 1
                pos = i + 1
                continue
            out.append(Frame(mtype, flags, counter, index, body[HEADER_LEN:]))
            self.stats.frames += 1
            pos = end
        del buf[:pos]
        return out


_CSV_ALLOWED = np.zeros(256, dtype=bool)
_CSV_ALLOWED[np.frombuffer(b"0123456789+-.eE, \t\r", np.uint8)] = True


class CsvDecoder:
    """ASCII line mode: one sample per line, ``v1,v2[,...]`` in ADC codes, '#' lines ignored.

    Vectorised over a chunk of complete lines: a line with the wrong number of fields or a
    character outside ``0-9 + - . e E , space tab CR`` is one lost sample (returned as
    ``bad`` so the tracker can mark a gap); its neighbours are kept.
    """

    def __init__(self, n_channels: int) -> None:
        self.n_channels = n_channels
        self._buf = bytearray()

    def feed(self, data: bytes) -> tuple[np.ndarray, np.ndarray]:
        """Return (values (n_lines, ch) float with NaN rows for bad lines, bad mask)."""
        self._buf += data
        cut = self._buf.rfind(b"\n") + 1
        if cut == 0:
            return np.empty((0, self.n_channels)), np.empty(0, dtype=bool)
        chunk = np.frombuffer(bytes(self._buf[:cut]), np.uint8)
        del self._buf[:cut]
        ends = np.flatnonzero(chunk == 10)
        starts = np.r_[0, ends[:-1] + 1]
        lengths = ends - starts  # without the newline
        comment = (lengths > 0) & (chunk[np.minimum(starts, chunk.size - 1)] == ord("#"))
        stripped = np.add.reduceat(((chunk != 13) & (chunk != 10)).astype(int), starts)
        keep = ~comment & (stripped > 0)
        commas = np.add.reduceat((chunk == 44).astype(int), starts)
        badch = np.add.reduceat((~_CSV_ALLOWED[chunk]).astype(int), starts) - 1  # minus '\n'
        good = keep & (commas == self.n_channels - 1) & (badch == 0)
        values = np.full((int(keep.sum()), self.n_channels), np.nan)
        good_k = good[keep]
        if good_k.any():
            mask = np.repeat(good, lengths + 1)
            try:
                parsed = np.loadtxt(io.BytesIO(chunk[mask].tobytes()), delimiter=",",
                                    ndmin=2, dtype=float)
            except ValueError:  # e.g. "1-2": allowed characters, not a number
                parsed = None
            if parsed is not None and parsed.shape == (int(good_k.sum()), self.n_channels):
                values[good_k] = parsed
            else:
                good_k[:] = False
        return values, ~good_k
