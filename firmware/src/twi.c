#include "twi.h"

#include <avr/io.h>
#include <util/delay.h>
#include <util/twi.h>

#include "config.h"

/* SCL = F_CPU / (16 + 2 TWBR 4^TWPS), prescaler 1 (ATmega328P data sheet,
 * 2-wire serial interface, bit rate generator unit). */
#define MOA_TWBR ((F_CPU / MOA_TWI_HZ - 16UL) / 2UL)
_Static_assert(F_CPU / MOA_TWI_HZ >= 16UL && MOA_TWBR <= 255UL, "TWI bit rate out of range");

void twi_init(void) {
  /* The bus needs pull-ups; the internal ones (tens of kOhm) are weak but
   * harmless next to a module's own. */
  PORTC |= _BV(PC4) | _BV(PC5);
  TWSR = 0;
  TWBR = (uint8_t)MOA_TWBR;
  TWCR = _BV(TWEN);
}

/* Starts a step with TWCR = `control` and waits for TWINT; the status
 * (TWSR without the prescaler bits), or 0xFF after MOA_TWI_TIMEOUT_US. */
static uint8_t step(uint8_t control) {
  TWCR = (uint8_t)(control | _BV(TWINT) | _BV(TWEN));
  /* Each pass takes at least 1 us: the wait ends within the bound. */
  for (uint8_t waited = 0; !(TWCR & _BV(TWINT)); ++waited) {
    if (waited >= MOA_TWI_TIMEOUT_US) return 0xFF;
    _delay_us(1);
  }
  return TW_STATUS;
}

/* Releases the bus: a STOP, or after a timeout the module switched off and
 * on (which also drops a half-done transfer). */
static bool finish(bool ok, uint8_t status) {
  if (status == 0xFF) {
    TWCR = 0;
    TWCR = _BV(TWEN);
  } else {
    TWCR = _BV(TWINT) | _BV(TWEN) | _BV(TWSTO);
  }
  return ok;
}

static uint8_t send_byte(uint8_t byte) {
  TWDR = byte;
  return step(0);
}

bool twi_write_register(uint8_t address, uint8_t reg, uint8_t value) {
  uint8_t s = step(_BV(TWSTA));
  if (s != TW_START) return finish(false, s);
  s = send_byte((uint8_t)(address << 1));
  if (s != TW_MT_SLA_ACK) return finish(false, s);
  s = send_byte(reg);
  if (s != TW_MT_DATA_ACK) return finish(false, s);
  s = send_byte(value);
  return finish(s == TW_MT_DATA_ACK, s);
}

bool twi_read_registers(uint8_t address, uint8_t reg, uint8_t* out, uint8_t n) {
  uint8_t s = step(_BV(TWSTA));
  if (s != TW_START) return finish(false, s);
  s = send_byte((uint8_t)(address << 1));
  if (s != TW_MT_SLA_ACK) return finish(false, s);
  s = send_byte(reg);
  if (s != TW_MT_DATA_ACK) return finish(false, s);
  s = step(_BV(TWSTA));
  if (s != TW_REP_START) return finish(false, s);
  s = send_byte((uint8_t)((uint8_t)(address << 1) | 1));
  if (s != TW_MR_SLA_ACK) return finish(false, s);
  for (uint8_t i = 0; i < n; ++i) {
    const bool last = i + 1u == n;
    s = step(last ? 0 : _BV(TWEA));
    if (s != (last ? TW_MR_DATA_NACK : TW_MR_DATA_ACK)) return finish(false, s);
    out[i] = TWDR;
  }
  return finish(true, s);
}
