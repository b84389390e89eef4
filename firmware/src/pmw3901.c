/* PMW3901 / PAA5100JE driver behind sensor.h; timings in pmw3901.h. */
#include "config.h"

#if MOA_FW_SENSOR == MOA_SENSOR_PMW3901 || MOA_FW_SENSOR == MOA_SENSOR_PAA5100
#include <avr/pgmspace.h>
#include <util/delay.h>

#include "board.h"
#include "pmw3901.h"
#include "sensor.h"
#include "spi.h"

static uint8_t reg_read(uint8_t sensor, uint8_t address) {
  cs_low(sensor);
  spi_transfer(address & 0x7f);
  _delay_us(50); /* t_SRAD, 35 us */
  const uint8_t value = spi_transfer(0);
  cs_high(sensor);
  _delay_us(20); /* t_SRR, t_SRW */
  return value;
}

static void reg_write(uint8_t sensor, uint8_t address, uint8_t value) {
  cs_low(sensor);
  spi_transfer(address | 0x80);
  spi_transfer(value);
  cs_high(sensor);
  _delay_us(50); /* t_SWW, t_SWR, 45 us */
}

static void run_steps(uint8_t sensor, const pmw3901_step_t* steps, uint8_t n) {
  for (uint8_t i = 0; i < n; ++i) {
    const uint8_t reg = pgm_read_byte(&steps[i].reg);
    const uint8_t value = pgm_read_byte(&steps[i].value);
    if (reg == PMW3901_WAIT) {
      for (uint8_t ms = 0; ms < value; ++ms) _delay_ms(1);
    } else {
      reg_write(sensor, reg, value);
    }
  }
}

void sensor_init_bus(uint8_t sensors) {
  cs_init(sensors);
  /* NRESET of a bare PMW3901, where wired to PD2: held high (inactive). */
  MOA_RESET_DDR |= _BV(MOA_RESET_BIT);
  MOA_RESET_PORT |= _BV(MOA_RESET_BIT);
  _delay_ms(1);
  for (uint8_t i = 0; i < sensors; ++i) {
    cs_low(i);
    cs_high(i);
    _delay_us(1);
    reg_write(i, PMW3901_POWER_UP_RESET, PMW3901_RESET_VALUE);
  }
  _delay_ms(5);
}

moa_sensor_status_t sensor_start(uint8_t sensor) {
  moa_sensor_status_t s = {MOA_SENSOR_OK, 0};
  for (uint8_t a = PMW3901_MOTION; a <= 0x06; ++a) reg_read(sensor, a);
  const uint8_t id = reg_read(sensor, PMW3901_PRODUCT_ID);
  if (id == 0x00 || id == 0xFF) {
    s.state = MOA_SENSOR_NO_ANSWER;
    return s;
  }
  if (id != PMW3901_PRODUCT_ID_VALUE ||
      reg_read(sensor, PMW3901_INVERSE_PRODUCT_ID) != (uint8_t)~PMW3901_PRODUCT_ID_VALUE) {
    s.state = MOA_SENSOR_WRONG_ID;
    s.detail = id;
    return s;
  }
  run_steps(sensor, pmw3901_init_a, pmw3901_init_a_length);
  reg_write(sensor, 0x48, (reg_read(sensor, 0x67) & 0x80) ? 0x04 : 0x02);
  run_steps(sensor, pmw3901_init_b, pmw3901_init_b_length);
  if (reg_read(sensor, 0x73) == 0x00) {
    /* Trim values of the chip, corrected as PixArt's sequence says (the
     * two tests in a row, as both public drivers apply them). */
    int16_t c1 = reg_read(sensor, 0x70);
    uint16_t c2 = reg_read(sensor, 0x71);
    if (c1 <= 28) c1 += 14;
    if (c1 > 28) c1 += 11;
    if (c1 > 0x3F) c1 = 0x3F;
    c2 = (uint16_t)(c2 * 45u / 100u);
    reg_write(sensor, 0x7F, 0x00);
    reg_write(sensor, 0x61, 0xAD);
    reg_write(sensor, 0x51, 0x70);
    reg_write(sensor, 0x7F, 0x0E);
    reg_write(sensor, 0x70, (uint8_t)c1);
    reg_write(sensor, 0x71, (uint8_t)c2);
  }
  run_steps(sensor, pmw3901_init_c, pmw3901_init_c_length);
  return s;
}

/* Counts per inch of a flow chip depend on its height: none to set. */
bool sensor_cpi_valid(uint16_t cpi) {
  (void)cpi;
  return false;
}

bool sensor_set_cpi(uint8_t sensor, uint16_t cpi) {
  (void)sensor;
  (void)cpi;
  return true;
}

void sensor_read(uint8_t sensor, moa_sample_t* out) {
  uint8_t b[PMW3901_BURST_LENGTH];
  cs_low(sensor);
  spi_transfer(PMW3901_MOTION_BURST);
  _delay_us(50); /* t_SRAD, 35 us */
  for (uint8_t i = 0; i < PMW3901_BURST_LENGTH; ++i) b[i] = spi_transfer(0);
  cs_high(sensor);
  _delay_us(1);
  /* Motion, Observation, Delta_X_L, _H, Delta_Y_L, _H, SQUAL, RawData_Sum,
   * Maximum_RawData, Minimum_RawData, Shutter_Upper, Shutter_Lower. */
  out->dx = (int16_t)(b[2] | (uint16_t)b[3] << 8);
  out->dy = (int16_t)(b[4] | (uint16_t)b[5] << 8);
  out->squal = b[6];
  out->shutter = (uint16_t)(b[10] << 8 | b[11]);
  out->flags = 0;
  if (b[6] < PMW3901_SQUAL_MIN && b[10] == PMW3901_SHUTTER_UPPER_MAX) {
    out->flags = MOA_SAMPLE_REJECTED;
  }
  if (bytes_silent(b, sizeof b)) out->flags = MOA_SAMPLE_SILENT;
}
#endif
