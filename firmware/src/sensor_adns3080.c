/* The ADNS-3080 behind sensor.h (adns3080.c has the register access). */
#include "config.h"

#if MOA_FW_SENSOR == MOA_SENSOR_ADNS3080
#include "adns3080.h"
#include "sensor.h"

void sensor_init_bus(uint8_t sensors) { adns3080_init_bus(sensors); }

moa_sensor_status_t sensor_start(uint8_t sensor) {
  moa_sensor_status_t s = {MOA_SENSOR_OK, 0};
  const uint8_t id = adns3080_read(sensor, ADNS3080_PRODUCT_ID);
  if (id == 0x00 || id == 0xFF) {
    s.state = MOA_SENSOR_NO_ANSWER;
  } else if (id != ADNS3080_PRODUCT_ID_VALUE) {
    s.state = MOA_SENSOR_WRONG_ID;
    s.detail = id;
  }
  return s;
}

bool sensor_cpi_valid(uint16_t cpi) { return cpi == 400 || cpi == 1600; }

bool sensor_set_cpi(uint8_t sensor, uint16_t cpi) { return adns3080_set_cpi(sensor, cpi); }

void sensor_read(uint8_t sensor, moa_sample_t* out) {
  adns3080_motion_t m;
  adns3080_motion_burst(sensor, &m);
  out->dx = m.dx;
  out->dy = m.dy;
  out->squal = m.squal;
  out->shutter = 0;
  out->flags = (m.motion & ADNS3080_MOTION_OVF) ? MOA_SAMPLE_OVERFLOW : 0;
  /* Motion's reserved bits 6:5 and 3:1 read 0 on a live chip, so a burst
   * of 0xFF is an undriven MISO. (All zeros is a lifted sensor at 400 cpi.) */
  if (m.motion == 0xFF && m.dx == -1 && m.dy == -1 && m.squal == 0xFF) {
    out->flags = MOA_SAMPLE_SILENT;
  }
}
#endif
