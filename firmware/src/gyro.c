#include "gyro.h"

#include <util/delay.h>

#include "twi.h"

bool gyro_init(void) {
  twi_init();
  uint8_t who = 0;
  if (!twi_read_registers(MPU6050_ADDRESS, MPU6050_WHO_AM_I, &who, 1)) return false;
  if (who != MPU6050_WHO_AM_I_VALUE) return false;
  /* Out of sleep, PLL on the X gyro (CLKSEL 1); then the gyro's settings. */
  if (!twi_write_register(MPU6050_ADDRESS, MPU6050_PWR_MGMT_1, 0x01)) return false;
  /* DLPF_CFG 2: 98 Hz gyro bandwidth, 2.8 ms delay, 1 kHz output, which
   * the frame reads (1 kHz and less) sample. */
  if (!twi_write_register(MPU6050_ADDRESS, MPU6050_CONFIG, 0x02)) return false;
  if (!twi_write_register(MPU6050_ADDRESS, MPU6050_SMPLRT_DIV, 0)) return false;
  if (!twi_write_register(MPU6050_ADDRESS, MPU6050_GYRO_CONFIG, (uint8_t)(MOA_GYRO_FS_SEL << 3)))
    return false;
  /* Gyro start-up (30 ms typical, data sheet). */
  _delay_ms(35);
  return true;
}

bool gyro_read_z(int16_t* z) {
  uint8_t b[2];
  if (!twi_read_registers(MPU6050_ADDRESS, MPU6050_GYRO_ZOUT_H, b, 2)) return false;
  /* Big-endian two's complement. */
  *z = (int16_t)(uint16_t)((uint16_t)b[0] << 8 | b[1]);
  return true;
}
