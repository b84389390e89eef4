#include "window.h"


void window_reset(moa_window_t* w) {
  w->sum_x = 0;
  w->sum_y = 0;
  w->max_shutter = 0;
  w->min_squal = 0xFF;
  w->flags = 0;
}

void window_add(moa_window_t* w, const moa_sample_t* s, uint8_t squal_floor) {
  if (s->flags & MOA_SAMPLE_SILENT) {
    w->flags |= MOA_FLAG_FAULT | MOA_FLAG_NO_SURFACE;
    w->min_squal = 0;
    return;
  }
  if (s->squal < w->min_squal) w->min_squal = s->squal;
  if (s->shutter > w->max_shutter) w->max_shutter = s->shutter;
  if (s->flags & MOA_SAMPLE_OVERFLOW) w->flags |= MOA_FLAG_OVERFLOW;
  if (s->squal < squal_floor) w->flags |= MOA_FLAG_NO_SURFACE;
  if (s->flags & MOA_SAMPLE_LIFT) {
    w->flags |= MOA_FLAG_NO_SURFACE;
    return;
  }
  if (s->flags & MOA_SAMPLE_REJECTED) {
    w->flags |= MOA_FLAG_REJECTED;
    return;
  }
  w->sum_x += s->dx;
  w->sum_y += s->dy;
}

void window_merge(moa_window_t* into, const moa_window_t* from) {
  into->sum_x += from->sum_x;
  into->sum_y += from->sum_y;
  if (from->min_squal < into->min_squal) into->min_squal = from->min_squal;
  if (from->max_shutter > into->max_shutter) into->max_shutter = from->max_shutter;
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
  r.shutter = w->max_shutter;
  return r;
}
