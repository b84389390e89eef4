#include "protocol.h"

#include <util/crc16.h>

#include "uart.h"

/* avr-libc's XMODEM update is the same polynomial, unreflected, without a
 * final XOR; only the initial value (0xFFFF here) differs, and that is the
 * caller's. Its assembly takes about 28 cycles a byte (measured in simavr),
 * a fraction of what a bit loop in C takes; at 8 MHz that decides whether
 * sending keeps up with the reads. */
uint16_t crc16_update(uint16_t crc, uint8_t byte) { return _crc_xmodem_update(crc, byte); }

void protocol_send(uint8_t* payload, uint8_t length) {
  uint16_t crc = 0xFFFF;
  for (uint8_t i = 0; i < length; ++i) crc = crc16_update(crc, payload[i]);
  payload[length] = (uint8_t)crc;
  payload[length + 1u] = (uint8_t)(crc >> 8);
  const uint8_t n = (uint8_t)(length + 2u);

  /* COBS: each zero becomes the length of the run before it, counted from
   * the code byte that opens the run. Payloads stay under 254 bytes, so no
   * run is ever full. */
  uint8_t frame[MOA_FRAME_MAX];
  uint8_t code_at = 0;
  uint8_t out = 1;
  for (uint8_t i = 0; i < n; ++i) {
    if (payload[i] == 0) {
      frame[code_at] = (uint8_t)(out - code_at);
      code_at = out++;
    } else {
      frame[out++] = payload[i];
    }
  }
  frame[code_at] = (uint8_t)(out - code_at);
  frame[out++] = 0;
  uart_tx_write(frame, out);
}

void command_reader_reset(moa_command_reader_t* r) {
  r->length = 0;
  r->overlong = false;
}

static bool decode(const moa_command_reader_t* r, moa_command_t* out) {
  uint8_t frame[MOA_COMMAND_MAX];
  uint8_t n = 0;
  uint8_t at = 0;
  while (at < r->length) {
    const uint8_t code = r->block[at++];
    const uint8_t run = (uint8_t)(code - 1u);
    if (run > r->length - at) return false;
    for (uint8_t i = 0; i < run; ++i) {
      if (n == sizeof frame) return false;
      frame[n++] = r->block[at++];
    }
    if (code != 0xFF && at < r->length) {
      if (n == sizeof frame) return false;
      frame[n++] = 0;
    }
  }
  if (n < 3) return false;
  uint16_t crc = 0xFFFF;
  for (uint8_t i = 0; i < n - 2u; ++i) crc = crc16_update(crc, frame[i]);
  if (frame[n - 2u] != (uint8_t)crc || frame[n - 1u] != (uint8_t)(crc >> 8)) return false;
  const uint8_t length = (uint8_t)(n - 2u);
  out->type = frame[0];
  out->value = 0;
  switch (frame[0]) {
    case MOA_TYPE_SET_K:
    case MOA_TYPE_SET_CPI:
      if (length != 3) return false;
      out->value = (uint16_t)(frame[1] | (uint16_t)frame[2] << 8);
      return true;
    case MOA_TYPE_HELLO_REQUEST:
      return length == 1;
    default:
      return false;
  }
}

bool command_reader_push(moa_command_reader_t* r, uint8_t byte, moa_command_t* out) {
  if (byte != 0) {
    if (r->length == sizeof r->block) {
      r->overlong = true;
    } else {
      r->block[r->length++] = byte;
    }
    return false;
  }
  const bool ok = !r->overlong && r->length > 0 && decode(r, out);
  command_reader_reset(r);
  return ok;
}
