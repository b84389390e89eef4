/* An MPU-6050 class gyro on the TWI bus (twi.h): the z rate, read once per
 * sensor frame and summed over the frames of a DATA window, like the counts
 * (docs/serial-protocol.md, GYRO). Registers from the MPU-6000/6050
 * register map. */
#ifndef MOA_FW_GYRO_H
#define MOA_FW_GYRO_H

#include <stdbool.h>
#include <stdint.h>

#define MPU6050_ADDRESS 0x68 /* AD0 low */
#define MPU6050_SMPLRT_DIV 0x19
#define MPU6050_CONFIG 0x1A
#define MPU6050_GYRO_CONFIG 0x1B
#define MPU6050_GYRO_ZOUT_H 0x47
#define MPU6050_PWR_MGMT_1 0x6B
#define MPU6050_WHO_AM_I 0x75
#define MPU6050_WHO_AM_I_VALUE 0x68

/* Full scale +-500 deg/s (GYRO_CONFIG FS_SEL = 1): 65.5 LSB per deg/s,
 * sent as 655 (LSB per deg/s times 10). */
#define MOA_GYRO_FS_SEL 1u
#define MOA_GYRO_LSB_PER_DPS_X10 655u
/* GYRO frame flags, bit 0: a sample of the window at full scale. */
#define MOA_GYRO_SATURATED 0x01u

/* Checks WHO_AM_I and sets the gyro up: awake, clocked from its own z gyro,
 * +-500 deg/s, low-pass at 98 Hz (DLPF_CFG 2), 1 kHz sampling. False when
 * no MPU-6050 answers or a write fails: the firmware then runs without it. */
bool gyro_init(void);
/* The latest z rate, raw LSB (counter-clockwise positive about the chip's
 * z axis); false on a bus error or timeout. */
bool gyro_read_z(int16_t* z);

#endif
