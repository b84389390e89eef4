/* TWI (I2C) master, polled, for the gyro (gyro.h). Pins: SDA PC4 [A4],
 * SCL PC5 [A5], shared with the chip selects of sensors 13 and 14 (board.h):
 * builds with the gyro take at most 12 sensors (config.h).
 *
 * Every wait for the bus is bounded (MOA_TWI_TIMEOUT_US per step): a
 * missing, held or broken device fails the transfer instead of hanging the
 * caller, which may be the frame interrupt. */
#ifndef MOA_FW_TWI_H
#define MOA_FW_TWI_H

#include <stdbool.h>
#include <stdint.h>

/* SCL 400 kHz (fast mode); the MPU-6050 allows it. */
#define MOA_TWI_HZ 400000UL
/* Longest wait for one step (a START, or a byte and its acknowledge: 9 SCL
 * periods, 22.5 us at 400 kHz), with margin. */
#define MOA_TWI_TIMEOUT_US 50u

void twi_init(void);
/* Writes `value` to register `reg` of the device at 7-bit `address`. */
bool twi_write_register(uint8_t address, uint8_t reg, uint8_t value);
/* Reads `n` (1..255) registers from `reg` on (the device increments the
 * register address): START, SLA+W, reg, repeated START, SLA+R, n bytes
 * (the last not acknowledged), STOP. False on a NACK or a timeout; `out`
 * is then incomplete. */
bool twi_read_registers(uint8_t address, uint8_t reg, uint8_t* out, uint8_t n);

#endif
