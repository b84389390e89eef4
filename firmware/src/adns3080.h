/* ADNS-3080 register access over SPI (Avago data sheet):
 * timing t_SRAD = 50 us (address to data of a read), t_SRAD-MOT = 75 us
 * (for Motion and Motion_Burst), t_SWW = t_SWR = 50 us (after a write),
 * t_BEXIT = 4 us (NCS high to leave burst mode), f_SCLK <= 2 MHz. */
#ifndef MOA_FW_ADNS3080_H
#define MOA_FW_ADNS3080_H

#include <stdbool.h>
#include <stdint.h>

#define ADNS3080_PRODUCT_ID 0x00
#define ADNS3080_MOTION 0x02
#define ADNS3080_CONFIGURATION_BITS 0x0a
#define ADNS3080_MOTION_BURST 0x50

#define ADNS3080_PRODUCT_ID_VALUE 0x17
#define ADNS3080_MOTION_MOT 0x80
#define ADNS3080_MOTION_OVF 0x10
#define ADNS3080_CONFIG_RES_1600 0x10

/* The first four bytes of a motion burst (the shutter and pixel bytes
 * that follow are not read: raising NCS ends the burst). */
typedef struct {
  uint8_t motion;
  int8_t dx;
  int8_t dy;
  uint8_t squal;
} adns3080_motion_t;

/* Chip-select pins as outputs, all deselected; RESET pulsed (10 us or
 * more), then the power-up wait before the first access. */
void adns3080_init_bus(uint8_t sensors);
uint8_t adns3080_read(uint8_t sensor, uint8_t address);
void adns3080_write(uint8_t sensor, uint8_t address, uint8_t value);
/* Product ID check; true if the sensor answers 0x17. */
bool adns3080_present(uint8_t sensor);
/* Sets 400 or 1600 cpi (Configuration_bits bit 4) and reads it back;
 * false if the sensor did not take it. */
bool adns3080_set_cpi(uint8_t sensor, uint16_t cpi);
void adns3080_motion_burst(uint8_t sensor, adns3080_motion_t* out);

#endif
