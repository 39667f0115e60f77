// batlab reference firmware: Teensy 4.1 + ADS1256 (24-bit, SPI) acquisition box.
// Streams hammer (AIN0/AIN1) and accelerometer (AIN2/AIN3) over USB CDC with the frame
// protocol of docs/protocol.md. Build notes in README.md next to this file.
// The ADS1256 multiplexes channels, so per-channel rates are limited (~2-4 kHz for two
// channels at 7.5/15 kSPS); for 51.2 kHz use an AD7768-4 (same frame code, different reader).
#include <Arduino.h>
#include <SPI.h>
#include "batbox_frame.h"

using namespace batbox;

namespace {
constexpr uint8_t PIN_CS = 10, PIN_DRDY = 9, PIN_RESET = 8;
constexpr uint8_t N_CH = 2;
constexpr float ADC_FULL_SCALE_V = 2.5f;     // +-2 Vref / PGA 1 with Vref 2.5 V (ADS1256)
constexpr float SENS_FORCE_MV_PER_N = 2.25f;  // from the hammer's calibration sheet
constexpr float SENS_ACCEL_MV_PER_G = 1.0f;   // from the accelerometer's calibration sheet
constexpr size_t RING = 8192;                 // samples (per channel) buffered for USB

volatile int32_t ring[RING][N_CH];
volatile uint32_t ring_head = 0, ring_tail = 0;
volatile uint32_t lost_samples = 0;
volatile bool overload_pending = false;

uint32_t counter = 0;        // device frame counter: +1 for every frame sent, any type
uint64_t next_index = 0;     // index of the next sample to send (reset by START)
bool streaming = false;
float sample_rate_hz = 2000.0f;
uint16_t samples_per_frame = 32;
uint32_t last_heartbeat_ms = 0;
CommandParser parser;
uint8_t txbuf[HEADER_LEN + MAX_PAYLOAD + TRAILER_LEN];

void flush_frames(bool partial);

void send(uint8_t type, uint8_t flags, uint64_t index, const uint8_t* payload, uint16_t len) {
  size_t n = encode_frame(txbuf, type, flags, counter++, index, payload, len);
  Serial.write(txbuf, n);
}

void send_ack(uint32_t cmd_counter, uint8_t opcode, uint8_t result, uint16_t arg) {
  uint8_t p[8];
  put_le(p, cmd_counter, 4); p[4] = opcode; p[5] = result; put_le(p + 6, arg, 2);
  send(ACK, 0, next_index, p, sizeof p);
}

void put_f32(uint8_t* p, float f) { uint32_t u; memcpy(&u, &f, 4); put_le(p, u, 4); }
void put_f64(uint8_t* p, double f) { uint64_t u; memcpy(&u, &f, 8); put_le(p, u, 8); }

void send_info() {
  uint8_t p[32 + 16 * N_CH] = {};
  p[0] = 1; p[1] = 1; p[2] = 0; p[3] = 0;   // protocol 1, firmware 1.0.0
  p[4] = N_CH; p[5] = 24; put_le(p + 6, samples_per_frame, 2);
  put_f64(p + 8, sample_rate_hz); put_f32(p + 16, ADC_FULL_SCALE_V);
  memcpy(p + 20, "teensy41-ads", 12);
  const uint8_t kinds[N_CH] = {0, 1};
  const char* units[N_CH] = {"N", "g"};
  const float sens[N_CH] = {SENS_FORCE_MV_PER_N, SENS_ACCEL_MV_PER_G};
  for (int c = 0; c < N_CH; ++c) {
    uint8_t* q = p + 32 + 16 * c;
    q[0] = kinds[c]; strncpy(reinterpret_cast<char*>(q + 1), units[c], 7);
    put_f32(q + 8, sens[c]);
  }
  send(INFO, 0, next_index, p, sizeof p);
}

// --- ADS1256 -----------------------------------------------------------------
int32_t ads_read_channel(uint8_t mux) {
  // WREG MUX, SYNC, WAKEUP, RDATA (datasheet fig. 19 cycling through the multiplexer)
  SPI.beginTransaction(SPISettings(1900000, MSBFIRST, SPI_MODE1));
  digitalWrite(PIN_CS, LOW);
  SPI.transfer(0x51); SPI.transfer(0x00); SPI.transfer(mux);
  SPI.transfer(0xFC); delayMicroseconds(4); SPI.transfer(0x00);
  SPI.transfer(0x01); delayMicroseconds(7);
  int32_t v = int32_t(SPI.transfer(0)) << 16; v |= int32_t(SPI.transfer(0)) << 8; v |= SPI.transfer(0);
  digitalWrite(PIN_CS, HIGH);
  SPI.endTransaction();
  return (v ^ 0x800000) - 0x800000;  // sign-extend 24 bits
}

IntervalTimer sampler;
void sample_isr() {
  int32_t s[N_CH] = {ads_read_channel(0x01), ads_read_channel(0x23)};
  bool over = false;
  for (int c = 0; c < N_CH; ++c) over |= (s[c] >= 0x7FFFFF || s[c] <= -0x7FFFFF);
  uint32_t next = (ring_head + 1) % RING;
  if (next == ring_tail) { ++lost_samples; return; }  // host too slow: count, report
  for (int c = 0; c < N_CH; ++c) ring[ring_head][c] = s[c];
  ring_head = next;
  if (over) overload_pending = true;
}

void handle_command(const uint8_t* f) {
  uint32_t cmd_counter = uint32_t(f[4]) | uint32_t(f[5]) << 8 | uint32_t(f[6]) << 16 | uint32_t(f[7]) << 24;
  uint16_t len = uint16_t(f[16] | (f[17] << 8));
  if (f[2] != COMMAND || len < 1) return;
  const uint8_t op = f[HEADER_LEN], *args = f + HEADER_LEN + 1;
  switch (op) {
    case GET_INFO: send_info(); send_ack(cmd_counter, op, ACK_OK, 0); break;
    case CONFIGURE: {
      if (streaming || len != 13) { send_ack(cmd_counter, op, streaming ? ACK_BAD_STATE : ACK_BAD_ARGUMENT, 0); break; }
      double rate; memcpy(&rate, args, 8);
      uint16_t spf = uint16_t(args[10] | (args[11] << 8));
      bool ok = args[8] == N_CH && args[9] == 24 && rate >= 100 && rate <= 4000 && spf >= 1 &&
                spf * N_CH * 3 <= MAX_PAYLOAD;
      if (ok) { sample_rate_hz = float(rate); samples_per_frame = spf; }
      send_ack(cmd_counter, op, ok ? ACK_OK : ACK_BAD_ARGUMENT, 0);
      break;
    }
    case START:
      noInterrupts(); ring_head = ring_tail = 0; lost_samples = 0; interrupts();
      next_index = 0; streaming = true;
      send_ack(cmd_counter, op, ACK_OK, 0);
      sampler.begin(sample_isr, 1e6f / sample_rate_hz);
      break;
    case STOP:
      sampler.end(); streaming = false;
      // drain: every sample already taken goes out before the ACK (no loss on shutdown)
      while (ring_tail != ring_head) flush_frames(true);
      send_ack(cmd_counter, op, ACK_OK, 0);
      break;
    case POINT: send_ack(cmd_counter, op, ACK_OK, uint16_t(args[0] | (args[1] << 8))); break;
    case PING: send_ack(cmd_counter, op, ACK_OK, 0); break;
    default: send_ack(cmd_counter, op, ACK_UNSUPPORTED, 0);
  }
}

void flush_frames(bool partial) {
  uint32_t avail = (ring_head + RING - ring_tail) % RING;
  if (lost_samples) {  // overrun: report, then jump the sample index so the host sees the gap
    noInterrupts(); uint32_t lost = lost_samples; lost_samples = 0; interrupts();
    uint8_t p[8] = {ST_OVERRUN, 0, 0, 0}; put_le(p + 4, lost, 4);
    send(STATUS, 0, next_index, p, sizeof p);
    next_index += lost;
  }
  if (avail == 0 || (!partial && avail < samples_per_frame)) return;
  uint16_t n = partial && avail < samples_per_frame ? uint16_t(avail) : samples_per_frame;
  static uint8_t payload[MAX_PAYLOAD];
  uint8_t* q = payload;
  for (uint16_t i = 0; i < n; ++i) {
    for (int c = 0; c < N_CH; ++c) q = put_s24(q, ring[ring_tail][c]);
    ring_tail = (ring_tail + 1) % RING;
  }
  bool over = overload_pending; overload_pending = false;
  send(DATA, data_flags(N_CH, true, over, false), next_index, payload, uint16_t(q - payload));
  next_index += n;
}
}  // namespace

void setup() {
  // Native USB CDC: opening the port (DTR) does not reset a Teensy, unlike Arduino Uno boards.
  Serial.begin(0);  // USB: the baud rate is ignored, 480 Mbit/s
  pinMode(PIN_CS, OUTPUT); digitalWrite(PIN_CS, HIGH);
  pinMode(PIN_DRDY, INPUT); pinMode(PIN_RESET, OUTPUT);
  digitalWrite(PIN_RESET, LOW); delay(1); digitalWrite(PIN_RESET, HIGH); delay(30);
  SPI.begin();
}

void loop() {
  while (Serial.available()) {
    if (parser.feed(uint8_t(Serial.read()))) { handle_command(parser.frame()); parser.consume(); }
  }
  if (streaming) {
    flush_frames(false);
  } else if (millis() - last_heartbeat_ms >= 500) {
    uint8_t p[8] = {}; put_le(p, millis(), 4);
    send(HEARTBEAT, 0, next_index, p, sizeof p);
    last_heartbeat_ms = millis();
  }
}
