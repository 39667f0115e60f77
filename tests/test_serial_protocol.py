"""Wire protocol: CRC check values, frame and payload round trips, resynchronisation."""

import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rigs import protocol as p
from rigs.stream import DataBlock, Gap, StreamTracker


def test_crc_check_values_of_the_spec():
    assert p.crc16_ccitt(b"123456789") == 0x29B1
    assert p.crc32(b"123456789") == 0xCBF43926


def test_frame_layout_matches_the_spec_byte_for_byte():
    f = p.encode_frame(p.DATA, 0x01020304, 0x1122334455667788, b"\x01\x02\x03", flags=0x09)
    assert f[:2] == b"\xa5\x5a" and f[2] == p.DATA and f[3] == 0x09
    assert f[4:8] == bytes([4, 3, 2, 1])
    assert f[8:16] == bytes([0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11])
    assert f[16:18] == b"\x03\x00"
    assert struct.unpack("<H", f[18:20])[0] == p.crc16_ccitt(f[:18])
    assert f[20:23] == b"\x01\x02\x03"
    assert struct.unpack("<I", f[23:27])[0] == p.crc32(f[:23]) and len(f) == 27


@settings(max_examples=30, deadline=None)
@given(n_ch=st.integers(2, 8), bits=st.sampled_from([16, 24]), n=st.integers(1, 50),
       seed=st.integers(0, 2**32 - 1))
def test_samples_round_trip_with_sign(n_ch, bits, n, seed):
    fs = 2 ** (bits - 1)
    codes = np.random.default_rng(seed).integers(-fs, fs, (n, n_ch)).astype(np.int32)
    codes[0, 0], codes[-1, -1] = -fs, fs - 1
    payload = p.encode_samples(codes, bits)
    assert len(payload) == n * n_ch * bits // 8
    np.testing.assert_array_equal(p.decode_samples(payload, n_ch, bits), codes)
    assert p.decode_data_format(p.data_flags(n_ch, bits)) == (n_ch, bits)


def test_24bit_is_little_endian_twos_complement():
    payload = bytes([0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x80, 0x01, 0x00, 0x00])
    np.testing.assert_array_equal(p.decode_samples(payload, 1, 24)[:, 0], [-1, -(2**23), 1])


def test_info_round_trip_and_scaling():
    info = p.DeviceInfo((p.Channel("force", "N", 2.25), p.Channel("acceleration", "g", 1.0),
                         p.Channel("voltage", "V", 1000.0)), 51200.0, 24, 5.0, 128, (2, 1, 7),
                        "teensy")
    back = p.decode_info(p.encode_info(info))
    assert back.channels[0] == info.channels[0] and back.firmware == (2, 1, 7)
    assert back.sample_rate_hz == 51200.0 and back.bits == 24 and back.name == "teensy"
    # one code on the force channel: 5 V / 2^23 / 2.25 mV/N; on the accelerometer in m/s^2
    np.testing.assert_allclose(back.scale_si()[:2], [5 / 2**23 / 2.25e-3,
                                                     5 / 2**23 / 1e-3 * 9.80665])
    with pytest.raises(ValueError, match="INFO"):
        p.decode_info(p.encode_info(info)[:-3])


def _stream(n_frames, spf=16, n_ch=2, bits=24, seed=0):
    rng = np.random.default_rng(seed)
    codes = rng.integers(-2**23, 2**23, (n_frames * spf, n_ch)).astype(np.int32)
    frames = [p.encode_frame(p.DATA, k, k * spf, p.encode_samples(codes[k * spf:(k + 1) * spf],
                                                                  bits), p.data_flags(n_ch, bits))
              for k in range(n_frames)]
    return codes, frames


def _decode_all(data: bytes, chunk: int):
    dec, tr, items = p.FrameDecoder(), StreamTracker(), []
    for i in range(0, len(data), chunk):
        for fr in dec.feed(data[i:i + chunk]):
            items += tr.push(fr)
    return dec, items


@settings(max_examples=20, deadline=None)
@given(chunk=st.integers(1, 200), garbage=st.lists(st.binary(min_size=0, max_size=40),
                                                   min_size=21, max_size=21))
def test_garbage_between_frames_costs_nothing(chunk, garbage):
    codes, frames = _stream(20)
    data = b"".join(g + f for g, f in zip(garbage, frames + [b""], strict=True))
    dec, items = _decode_all(data, chunk)
    blocks = [i for i in items if isinstance(i, DataBlock)]
    assert not [i for i in items if isinstance(i, Gap)]
    np.testing.assert_array_equal(np.vstack([b.codes for b in blocks]), codes)


def test_bit_flip_dropped_and_truncated_frames_become_exact_gaps():
    codes, frames = _stream(12)
    flipped = bytearray(frames[3])
    flipped[30] ^= 0x04  # payload bit: frame CRC fails
    hdr = bytearray(frames[9])
    hdr[10] ^= 0x80  # header bit: header CRC fails
    data = (b"".join(frames[:3]) + bytes(flipped) + frames[4] + frames[6]  # 5 dropped
            + frames[7][:25] + frames[8] + bytes(hdr) + frames[10] + frames[11])  # 7 truncated
    dec, items = _decode_all(data, 64)
    gaps = [(g.start, g.stop) for g in items if isinstance(g, Gap)]
    assert gaps == [(48, 64), (80, 96), (112, 128), (144, 160)]
    got = np.vstack([b.codes for b in items if isinstance(b, DataBlock)])
    keep = np.r_[0:48, 64:80, 96:112, 128:144, 160:192]
    np.testing.assert_array_equal(got, codes[keep])
    assert dec.stats.crc_errors == 2 and dec.stats.header_errors >= 1


def test_lost_non_data_frame_is_a_point_gap_and_counter_wraps():
    tr = StreamTracker()
    info = p.encode_frame(p.HEARTBEAT, 2**32 - 1, 0, p.encode_heartbeat(0, True))
    f0 = p.encode_frame(p.DATA, 0, 0, p.encode_samples(np.zeros((4, 2)), 16), p.data_flags(2, 16))
    f2 = p.encode_frame(p.DATA, 2, 4, p.encode_samples(np.zeros((4, 2)), 16), p.data_flags(2, 16))
    dec = p.FrameDecoder()
    items = [i for fr in dec.feed(info + f0 + f2) for i in tr.push(fr)]
    gaps = [i for i in items if isinstance(i, Gap)]
    assert len(gaps) == 1 and gaps[0].start == gaps[0].stop == 4  # counter 0xFFFFFFFF -> 0 ok
    assert "1 frame(s) lost" in gaps[0].reason


def test_oversized_length_is_rejected_without_waiting():
    _, frames = _stream(2)
    bad = bytearray(p.HEADER.pack(p.SYNC, p.DATA, 0, 0, 0, 60000))
    bad += struct.pack("<H", p.crc16_ccitt(bytes(bad)))
    dec = p.FrameDecoder()
    out = dec.feed(bytes(bad) + frames[0] + frames[1])
    assert [f.counter for f in out] == [0, 1] and dec.pending == 0


def test_csv_line_mode_marks_bad_lines_as_lost_samples():
    dec = p.CsvDecoder(2)
    vals, bad = dec.feed(b"# batlab csv\n1,2\n3,-4\r\n5;6\n7,8,9\n10,1e2\n11,x\n12")
    np.testing.assert_array_equal(bad, [False, False, True, True, False, True])
    np.testing.assert_array_equal(vals[~bad], [[1, 2], [3, -4], [10, 100]])
    vals, bad = dec.feed(b",13\n")
    np.testing.assert_array_equal(vals, [[12, 13]])


HARNESS = r"""
#include "batbox_frame.h"
#include <cassert>
#include <cstdio>
int main() {
  const uint8_t* s = (const uint8_t*)"123456789";
  assert(batbox::crc16_ccitt(s, 9) == 0x29B1 && batbox::crc32_ieee(s, 9) == 0xCBF43926u);
  uint8_t pl[6], out[64];
  batbox::put_s24(batbox::put_s24(pl, -5), 8388607);
  size_t n = batbox::encode_frame(out, batbox::DATA, batbox::data_flags(2, true, true, false),
                                  7, 123, pl, 6);
  batbox::CommandParser parser;
  bool ok = false;
  for (size_t i = 0; i < n; ++i) ok = parser.feed(out[i]);
  assert(ok && parser.length() == n);
  fwrite(out, 1, n, stdout);
}
"""


def test_firmware_frame_code_matches_the_host(tmp_path):
    import shutil
    import subprocess
    from pathlib import Path

    if not shutil.which("g++"):
        pytest.skip("no C++ compiler")
    fw = Path(__file__).resolve().parents[1] / "rigs" / "firmware"
    (tmp_path / "t.cpp").write_text(HARNESS)
    subprocess.run(["g++", "-std=c++17", "-Wall", "-Werror", f"-I{fw}", str(tmp_path / "t.cpp"),
                    "-o", str(tmp_path / "t")], check=True, timeout=60)
    wire = subprocess.run([str(tmp_path / "t")], capture_output=True, check=True,
                          timeout=10).stdout
    assert wire == p.encode_frame(p.DATA, 7, 123, p.encode_samples(np.array([[-5, 2**23 - 1]]),
                                                                   24),
                                  p.data_flags(2, 24, overload=True))
