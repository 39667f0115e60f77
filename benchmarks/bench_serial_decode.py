"""Decode speed of the serial stream: 4 channels, 24-bit, 51.2 kHz, vs real time.

Encodes N seconds of stream (frames of 256 samples, ~0.6 MB/s on the wire), then feeds it to
FrameDecoder + StreamTracker in 4 KiB reads (as the driver's reader thread does) and reports
the multiple of real time, next to a per-sample reference decoder (struct.unpack per value)
in the same process. Run: python benchmarks/bench_serial_decode.py [seconds]
"""

from __future__ import annotations

import struct
import sys
import time

import numpy as np

from rigs import protocol as p
from rigs.stream import DataBlock, StreamTracker

FS, N_CH, BITS, SPF = 51200.0, 4, 24, 256


def make_stream(seconds: float) -> tuple[bytes, np.ndarray]:
    n = int(seconds * FS) // SPF * SPF
    codes = np.random.default_rng(0).integers(-2**23, 2**23, (n, N_CH)).astype(np.int32)
    flags = p.data_flags(N_CH, BITS)
    wire = b"".join(p.encode_frame(p.DATA, k, k * SPF,
                                   p.encode_samples(codes[k * SPF:(k + 1) * SPF], BITS), flags)
                    for k in range(n // SPF))
    return wire, codes


def decode_vectorised(wire: bytes, chunk: int = 4096) -> int:
    dec, tr, n = p.FrameDecoder(), StreamTracker(), 0
    for i in range(0, len(wire), chunk):
        for fr in dec.feed(wire[i:i + chunk]):
            for item in tr.push(fr):
                if isinstance(item, DataBlock):
                    n += item.codes.shape[0]
    return n


def decode_per_sample(wire: bytes) -> int:
    """Reference: the same frames, each 24-bit value unpacked in a Python loop."""
    dec, n = p.FrameDecoder(), 0
    for fr in dec.feed(wire):
        pl = fr.payload
        vals = []
        for j in range(0, len(pl), 3):
            (v,) = struct.unpack("<i", pl[j:j + 3] + (b"\xff" if pl[j + 2] & 0x80 else b"\0"))
            vals.append(v)
        n += len(vals) // N_CH
    return n


def main() -> None:
    seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 10.0
    wire, codes = make_stream(seconds)
    real = codes.shape[0] / FS
    t = time.perf_counter()
    n = decode_vectorised(wire)
    dt = time.perf_counter() - t
    assert n == codes.shape[0]
    ref_s = min(real, 1.0)
    ref_wire, ref_codes = make_stream(ref_s)
    t = time.perf_counter()
    assert decode_per_sample(ref_wire) == ref_codes.shape[0]
    dt_ref = (time.perf_counter() - t) * real / (ref_codes.shape[0] / FS)
    print(f"stream: {N_CH} ch x {BITS} bit at {FS:.0f} Hz, {real:.1f} s, "
          f"{len(wire) / 1e6:.1f} MB ({len(wire) / real / 1e3:.0f} kB/s)")
    print(f"vectorised decode: {dt:.3f} s = {real / dt:.0f}x real time "
          f"({len(wire) / dt / 1e6:.0f} MB/s)")
    print(f"per-sample reference: {dt_ref:.3f} s = {real / dt_ref:.1f}x real time; "
          f"speed-up {dt_ref / dt:.0f}x")


if __name__ == "__main__":
    main()
