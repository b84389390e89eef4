#include <util/delay.h>

#include "board.h"
#include "config.h"
#include "sensor.h"

static const moa_pin_t cs_pins[] = MOA_CS_PIN_TABLE;

void cs_init(uint8_t sensors) {
  for (uint8_t i = 0; i < sensors; ++i) {
    *cs_pins[i].port |= cs_pins[i].mask;
    *cs_pins[i].ddr |= cs_pins[i].mask;
  }
}

void cs_low(uint8_t sensor) {
  *cs_pins[sensor].port &= (uint8_t)~cs_pins[sensor].mask;
  /* t_NCS-SCLK, 120 ns for every PixArt part here, with margin. */
  _delay_us(1);
}

void cs_high(uint8_t sensor) { *cs_pins[sensor].port |= cs_pins[sensor].mask; }

bool bytes_silent(const uint8_t* bytes, uint8_t n) {
  uint8_t all_and = 0xFF;
  uint8_t all_or = 0x00;
  for (uint8_t i = 0; i < n; ++i) {
    all_and &= bytes[i];
    all_or |= bytes[i];
  }
  return all_and == 0xFF || all_or == 0x00;
}
