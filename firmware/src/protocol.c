#include "protocol.h"

#include "uart.h"

uint16_t crc16_update(uint16_t crc, uint8_t byte) {
  crc ^= (uint16_t)byte << 8;
  for (uint8_t bit = 0; bit < 8; ++bit) {
    crc = (crc & 0x8000u) ? (uint16_t)((crc << 1) ^ 0x1021u) : (uint16_t)(crc << 1);
  }
  return crc;
}

/* COBS of n bytes: one code byte per run of up to 254 non-zero bytes. */
static uint8_t encoded_length(uint8_t n) { return (uint8_t)(n + 1u + n / 254u); }

bool protocol_send(uint8_t* payload, uint8_t length, bool wait) {
  uint16_t crc = 0xFFFF;
  for (uint8_t i = 0; i < length; ++i) crc = crc16_update(crc, payload[i]);
  payload[length] = (uint8_t)crc;
  payload[length + 1u] = (uint8_t)(crc >> 8);
  const uint8_t n = (uint8_t)(length + 2u);

  const uint8_t needed = (uint8_t)(encoded_length(n) + 1u);
  while (uart_tx_free() < needed) {
    if (!wait) return false;
  }

  /* COBS with look-ahead: the whole block is in memory, so each run's
   * code is known before its bytes go out and the ring can be fed in
   * order while the interrupt is already sending. */
  uint8_t at = 0;
  for (;;) {
    uint8_t run = 0;
    while (at + run < n && payload[at + run] != 0 && run < 254u) ++run;
    uart_tx_put((uint8_t)(run + 1u));
    for (uint8_t i = 0; i < run; ++i) uart_tx_put(payload[at + i]);
    at = (uint8_t)(at + run);
    if (run == 254u) {
      /* A full run carries no zero; stop if nothing follows. */
      if (at >= n) break;
      continue;
    }
    if (at >= n) break;
    ++at; /* the zero this run ended on */
  }
  uart_tx_put(0);
  return true;
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
