#include "clock.h"

#include <avr/interrupt.h>
#include <util/atomic.h>

#include "board.h"
#include "config.h"

static volatile uint32_t tick_time;
static volatile uint8_t ticks_due;

void clock_start(void) {
  TCCR1A = 0;
  TCNT1 = 0;
  OCR1A = (uint16_t)(MOA_FW_FRAME_TICKS - 1UL);
  /* CTC on OCR1A, prescaler 8. */
  TCCR1B = _BV(WGM12) | _BV(CS11);
  MOA_TIMSK1 |= _BV(OCIE1A);
}

ISR(TIMER1_COMPA_vect) {
  tick_time += MOA_FW_FRAME_TICKS;
  if (ticks_due != 0xFF) ++ticks_due;
}

uint8_t clock_take_ticks(uint32_t* latest) {
  uint8_t due;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    due = ticks_due;
    ticks_due = 0;
    *latest = tick_time;
  }
  return due;
}

bool clock_tick_pending(void) { return ticks_due != 0; }
