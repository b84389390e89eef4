/* One sensor's accumulation window: the Kim & Lee downsampler (their
 * Section V, eq. (50)): the counts of K sensor frames are summed and sent
 * as one record. */
#ifndef MOA_FW_WINDOW_H
#define MOA_FW_WINDOW_H

#include <stdint.h>

#include "sensor.h"

#define MOA_FLAG_OVERFLOW 0x01   /* OVF seen in the window, or the sum saturated */
#define MOA_FLAG_NO_SURFACE 0x02 /* SQUAL fell below the floor, or the chip said lift */
#define MOA_FLAG_REJECTED 0x04   /* the sensor's quality rule refused some reads' counts */
#define MOA_FLAG_FAULT 0x08      /* the sensor did not answer some reads (sensor.h) */

typedef struct {
  /* K <= 1000 frames of |d| <= 32768 counts: |sum| <= 2^25, fits 32 bits. */
  int32_t sum_x;
  int32_t sum_y;
  uint16_t max_shutter;
  uint8_t min_squal;
  uint8_t flags;
} moa_window_t;

typedef struct {
  int16_t dx;
  int16_t dy;
  uint8_t squal;
  uint8_t flags;
  uint16_t shutter; /* the longest exposure of the window */
} moa_record_t;

void window_reset(moa_window_t* w);
/* Adds one read. Counts of a read that is silent, lifted or rejected are
 * left out (the chip's counts mean nothing then); its flags are kept. */
void window_add(moa_window_t* w, const moa_sample_t* s, uint8_t squal_floor);
/* Adds window `from` to `into`, as if its frames had been added one by one
 * (sums in 32 bits: a few windows of K <= 1000 frames stay far inside). */
void window_merge(moa_window_t* into, const moa_window_t* from);
/* The record of the window: sums saturated to int16 (then flags bit 0). */
moa_record_t window_record(const moa_window_t* w);

#endif
