#include "window.h"

#include "adns3080.h"

void window_reset(moa_window_t* w) {
  w->sum_x = 0;
  w->sum_y = 0;
  w->min_squal = 0xFF;
  w->flags = 0;
}

void window_add(moa_window_t* w, uint8_t motion, int8_t dx, int8_t dy, uint8_t squal,
                uint8_t squal_floor) {
  w->sum_x += dx;
  w->sum_y += dy;
  if (squal < w->min_squal) w->min_squal = squal;
  if (motion & ADNS3080_MOTION_OVF) w->flags |= MOA_FLAG_OVERFLOW;
  if (squal < squal_floor) w->flags |= MOA_FLAG_NO_SURFACE;
}

void window_merge(moa_window_t* into, const moa_window_t* from) {
  into->sum_x += from->sum_x;
  into->sum_y += from->sum_y;
  if (from->min_squal < into->min_squal) into->min_squal = from->min_squal;
  into->flags |= from->flags;
}

static int16_t saturate(int32_t sum, uint8_t* flags) {
  if (sum > INT16_MAX) {
    *flags |= MOA_FLAG_OVERFLOW;
    return INT16_MAX;
  }
  if (sum < INT16_MIN) {
    *flags |= MOA_FLAG_OVERFLOW;
    return INT16_MIN;
  }
  return (int16_t)sum;
}

moa_record_t window_record(const moa_window_t* w) {
  moa_record_t r;
  r.flags = w->flags;
  r.dx = saturate(w->sum_x, &r.flags);
  r.dy = saturate(w->sum_y, &r.flags);
  r.squal = w->min_squal;
  return r;
}
