#include "adns3080.h"

#include <util/delay.h>

#include "board.h"
#include "config.h"
#include "spi.h"

static const moa_pin_t cs_pins[] = MOA_CS_PIN_TABLE;

static void select_sensor(uint8_t sensor) {
  *cs_pins[sensor].port &= (uint8_t)~cs_pins[sensor].mask;
  /* t_NCS-SCLK, 120 ns, with margin. */
  _delay_us(1);
}

static void deselect_sensor(uint8_t sensor) { *cs_pins[sensor].port |= cs_pins[sensor].mask; }

void adns3080_init_bus(uint8_t sensors) {
  for (uint8_t i = 0; i < sensors; ++i) {
    *cs_pins[i].port |= cs_pins[i].mask;
    *cs_pins[i].ddr |= cs_pins[i].mask;
  }
  MOA_RESET_DDR |= _BV(MOA_RESET_BIT);
  MOA_RESET_PORT |= _BV(MOA_RESET_BIT);
  _delay_us(20);
  MOA_RESET_PORT &= (uint8_t)~_BV(MOA_RESET_BIT);
  /* Far longer than the sensor's own start-up after a reset pulse; the
   * margin also covers the supply settling at power-up. */
  _delay_ms(50);
}

uint8_t adns3080_read(uint8_t sensor, uint8_t address) {
  select_sensor(sensor);
  spi_transfer(address & 0x7f);
  if (address == ADNS3080_MOTION) {
    _delay_us(75);
  } else {
    _delay_us(50);
  }
  const uint8_t value = spi_transfer(0);
  deselect_sensor(sensor);
  /* t_SRR / t_SRW, 250 ns. */
  _delay_us(1);
  return value;
}

void adns3080_write(uint8_t sensor, uint8_t address, uint8_t value) {
  select_sensor(sensor);
  spi_transfer(address | 0x80);
  spi_transfer(value);
  deselect_sensor(sensor);
  /* t_SWW / t_SWR before the next command. */
  _delay_us(50);
}

bool adns3080_present(uint8_t sensor) {
  return adns3080_read(sensor, ADNS3080_PRODUCT_ID) == ADNS3080_PRODUCT_ID_VALUE;
}

bool adns3080_set_cpi(uint8_t sensor, uint16_t cpi) {
  uint8_t config = adns3080_read(sensor, ADNS3080_CONFIGURATION_BITS);
  if (cpi == 1600) {
    config |= ADNS3080_CONFIG_RES_1600;
  } else {
    config &= (uint8_t)~ADNS3080_CONFIG_RES_1600;
  }
  adns3080_write(sensor, ADNS3080_CONFIGURATION_BITS, config);
  return adns3080_read(sensor, ADNS3080_CONFIGURATION_BITS) == config;
}

void adns3080_motion_burst(uint8_t sensor, adns3080_motion_t* out) {
  select_sensor(sensor);
  spi_transfer(ADNS3080_MOTION_BURST);
  _delay_us(75);
  out->motion = spi_transfer(0);
  out->dx = (int8_t)spi_transfer(0);
  out->dy = (int8_t)spi_transfer(0);
  out->squal = spi_transfer(0);
  deselect_sensor(sensor);
  _delay_us(4);
}
