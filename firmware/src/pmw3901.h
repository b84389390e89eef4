/* PixArt PMW3901MB-TXQT and PAA5100JE-Q optical flow chips (one register
 * interface; each its own init sequence, pmw3901_init.c). SPI mode 3,
 * f_SCLK <= 2 MHz, and between bytes (PMW3901MB data sheet, AC table):
 *   t_SRAD        35 us  read: address to data (also Motion_Burst)
 *   t_SWW, t_SWR  45 us  after a write, before the next command
 *   t_SRW, t_SRR  20 us  after a read, before the next command
 *   power-up       1 ms  after Power_Up_Reset, before the first read
 * The firmware waits 50 us where 35 or 45 are asked, as Bitcraze's driver
 * does. Motion: bit 7 MOT. Product ID 0x49, Inverse_Product_ID 0xB6. */
#ifndef MOA_FW_PMW3901_H
#define MOA_FW_PMW3901_H

#include <stdint.h>

#define PMW3901_PRODUCT_ID 0x00
#define PMW3901_MOTION 0x02
#define PMW3901_MOTION_BURST 0x16
#define PMW3901_POWER_UP_RESET 0x3A
#define PMW3901_INVERSE_PRODUCT_ID 0x5F
#define PMW3901_BANK 0x7F /* register bank select of the init sequence */

#define PMW3901_PRODUCT_ID_VALUE 0x49
#define PMW3901_RESET_VALUE 0x5A
#define PMW3901_BURST_LENGTH 12

/* Quality rule of PixArt's application note, as both public drivers apply
 * it: a frame with SQUAL < 0x19 while the shutter is at its ceiling
 * (Shutter_Upper 0x1F) carries no trustworthy motion. */
#define PMW3901_SQUAL_MIN 0x19
#define PMW3901_SHUTTER_UPPER_MAX 0x1F

/* Init sequence entries: a register and its value; a register of
 * PMW3901_WAIT means "wait value milliseconds". */
#define PMW3901_WAIT 0xFF
typedef struct {
  uint8_t reg;
  uint8_t value;
} pmw3901_step_t;

/* The parts of the sequence (flash), around its two reads (pmw3901.c). */
extern const pmw3901_step_t pmw3901_init_a[];
extern const uint8_t pmw3901_init_a_length;
extern const pmw3901_step_t pmw3901_init_b[];
extern const uint8_t pmw3901_init_b_length;
extern const pmw3901_step_t pmw3901_init_c[];
extern const uint8_t pmw3901_init_c_length;

#endif
