// batlab acquisition-box frame layer (docs/protocol.md). Portable C++ (no Arduino headers),
// shared by the Teensy firmware and any host-side test harness.
// Frame: A5 5A | type u8 | flags u8 | counter u32 | first_index u64 | length u16 |
//        CRC-16/CCITT-FALSE u16 over bytes 0..17 | payload | CRC-32/IEEE u32 over 0..19+length
// Little-endian. Check values: crc16("123456789") = 0x29B1, crc32("123456789") = 0xCBF43926.
#pragma once
#include <stddef.h>
#include <stdint.h>

namespace batbox {

enum MsgType : uint8_t { INFO = 0x01, DATA = 0x02, STATUS = 0x03, HEARTBEAT = 0x04,
                         COMMAND = 0x10, ACK = 0x11 };
enum Opcode : uint8_t { GET_INFO = 0x01, CONFIGURE = 0x02, START = 0x03, STOP = 0x04,
                        POINT = 0x05, PING = 0x06 };
enum AckResult : uint8_t { ACK_OK = 0, ACK_UNSUPPORTED = 1, ACK_BAD_ARGUMENT = 2,
                           ACK_BAD_STATE = 3 };
enum DataFlags : uint8_t { FLAG_24BIT = 0x08, FLAG_OVERLOAD = 0x10, FLAG_FAULT = 0x20 };
enum StatusBits : uint8_t { ST_OVERLOAD = 0x01, ST_OVERRUN = 0x02, ST_FAULT = 0x04 };

constexpr size_t HEADER_LEN = 20, TRAILER_LEN = 4, MAX_PAYLOAD = 4096;

inline uint16_t crc16_ccitt(const uint8_t* p, size_t n, uint16_t crc = 0xFFFF) {
  for (size_t i = 0; i < n; ++i) {
    crc ^= uint16_t(p[i]) << 8;
    for (int b = 0; b < 8; ++b) crc = (crc & 0x8000) ? uint16_t((crc << 1) ^ 0x1021) : uint16_t(crc << 1);
  }
  return crc;
}

inline uint32_t crc32_ieee(const uint8_t* p, size_t n, uint32_t crc = 0) {
  crc = ~crc;  // reflected poly 0xEDB88320, init 0xFFFFFFFF, final xor 0xFFFFFFFF
  for (size_t i = 0; i < n; ++i) {
    crc ^= p[i];
    for (int b = 0; b < 8; ++b) crc = (crc & 1) ? (crc >> 1) ^ 0xEDB88320u : crc >> 1;
  }
  return ~crc;
}

inline void put_le(uint8_t* p, uint64_t v, int n) {
  for (int i = 0; i < n; ++i) p[i] = uint8_t(v >> (8 * i));
}

// Writes a whole frame into out (HEADER_LEN + len + TRAILER_LEN bytes); returns its size.
inline size_t encode_frame(uint8_t* out, uint8_t type, uint8_t flags, uint32_t counter,
                           uint64_t first_index, const uint8_t* payload, uint16_t len) {
  out[0] = 0xA5; out[1] = 0x5A; out[2] = type; out[3] = flags;
  put_le(out + 4, counter, 4);
  put_le(out + 8, first_index, 8);
  put_le(out + 16, len, 2);
  put_le(out + 18, crc16_ccitt(out, 18), 2);
  for (uint16_t i = 0; i < len; ++i) out[HEADER_LEN + i] = payload[i];
  put_le(out + HEADER_LEN + len, crc32_ieee(out, HEADER_LEN + len), 4);
  return HEADER_LEN + len + TRAILER_LEN;
}

// DATA flags: bits 0-2 = n_channels - 1, bit 3 = 24-bit samples, bit 4 overload, bit 5 fault.
inline uint8_t data_flags(uint8_t n_channels, bool is24, bool overload, bool fault) {
  return uint8_t((n_channels - 1) & 7) | (is24 ? FLAG_24BIT : 0) |
         (overload ? FLAG_OVERLOAD : 0) | (fault ? FLAG_FAULT : 0);
}

// One 24-bit two's-complement sample, little-endian (low byte first).
inline uint8_t* put_s24(uint8_t* p, int32_t v) {
  p[0] = uint8_t(v); p[1] = uint8_t(v >> 8); p[2] = uint8_t(v >> 16);
  return p + 3;
}

// Incremental parser for host commands (same resynchronisation rule as the host: on a bad
// header or frame CRC, restart the search one byte after the sync word).
class CommandParser {
 public:
  // Feed one byte; returns true when a complete, CRC-valid frame is in frame()/length().
  bool feed(uint8_t byte) {
    if (n_ < sizeof(buf_)) buf_[n_++] = byte; else n_ = 0;
    for (;;) {
      if (n_ >= 1 && buf_[0] != 0xA5) { shift(1); continue; }
      if (n_ >= 2 && buf_[1] != 0x5A) { shift(1); continue; }
      if (n_ < HEADER_LEN) return false;
      uint16_t len = uint16_t(buf_[16] | (buf_[17] << 8));
      uint16_t hcrc = uint16_t(buf_[18] | (buf_[19] << 8));
      if (hcrc != crc16_ccitt(buf_, 18) || len > sizeof(buf_) - HEADER_LEN - TRAILER_LEN) {
        shift(1); continue;
      }
      size_t total = HEADER_LEN + len + TRAILER_LEN;
      if (n_ < total) return false;
      const uint8_t* t = buf_ + HEADER_LEN + len;
      uint32_t fcrc = uint32_t(t[0]) | uint32_t(t[1]) << 8 | uint32_t(t[2]) << 16 | uint32_t(t[3]) << 24;
      if (fcrc != crc32_ieee(buf_, HEADER_LEN + len)) { shift(1); continue; }
      len_ = total;
      return true;
    }
  }
  const uint8_t* frame() const { return buf_; }
  size_t length() const { return len_; }
  void consume() { shift(len_); len_ = 0; }

 private:
  void shift(size_t k) {
    for (size_t i = k; i < n_; ++i) buf_[i - k] = buf_[i];
    n_ -= k;
  }
  uint8_t buf_[128] = {};
  size_t n_ = 0, len_ = 0;
};

}  // namespace batbox
