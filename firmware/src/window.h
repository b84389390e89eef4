/* One sensor's accumulation window: the Kim & Lee downsampler (their
 * Section V, eq. (50)): the counts of K sensor frames are summed and sent
 * as one record. */
#ifndef MOA_FW_WINDOW_H
#define MOA_FW_WINDOW_H

#include <stdint.h>

#define MOA_FLAG_OVERFLOW 0x01   /* OVF seen in the window, or the sum saturated */
#define MOA_FLAG_NO_SURFACE 0x02 /* SQUAL fell below the floor (lift) */

typedef struct {
  /* K <= 1000 frames of |d| <= 128 counts: |sum| <= 128000, needs 18 bits. */
  int32_t sum_x;
  int32_t sum_y;
  uint8_t min_squal;
  uint8_t flags;
} moa_window_t;

typedef struct {
  int16_t dx;
  int16_t dy;
  uint8_t squal;
  uint8_t flags;
} moa_record_t;

void window_reset(moa_window_t* w);
/* Adds one motion burst: motion register, Delta_X, Delta_Y, SQUAL. */
void window_add(moa_window_t* w, uint8_t motion, int8_t dx, int8_t dy, uint8_t squal,
                uint8_t squal_floor);
/* Adds window `from` to `into`, as if its frames had been added one by one
 * (sums in 32 bits: a few windows of K <= 1000 frames stay far inside). */
void window_merge(moa_window_t* into, const moa_window_t* from);
/* The record of the window: sums saturated to int16 (then flags bit 0). */
moa_record_t window_record(const moa_window_t* w);

#endif
