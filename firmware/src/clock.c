#include "clock.h"

#include <avr/interrupt.h>
#include <stdbool.h>

#include "board.h"
#include "config.h"

static uint32_t tick_time;
static volatile bool in_frame;

void clock_start(void) {
  TCCR1A = 0;
  TCNT1 = 0;
  OCR1A = (uint16_t)(MOA_FW_FRAME_TICKS - 1UL);
  /* CTC on OCR1A, prescaler 8. */
  TCCR1B = _BV(WGM12) | _BV(CS11);
  MOA_TIMSK1 |= _BV(OCIE1A);
}

/* Interrupts are enabled again at once: the UART interrupts (a byte every
 * 20 us at 500 kbaud) must not wait for a whole frame of sensor reads. */
ISR(TIMER1_COMPA_vect, ISR_NOBLOCK) {
  tick_time += MOA_FW_FRAME_TICKS;
  /* A frame that overruns its period must not be re-entered; the time still
   * advances, so timestamps stay right and the host sees a longer window. */
  if (in_frame) return;
  in_frame = true;
  frame_tick(tick_time);
  in_frame = false;
}
