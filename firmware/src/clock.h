/* Frame clock and timestamps. Timer1 counts F_CPU/8 ticks (MOA_FW_TICK_HZ,
 * declared in HELLO) and fires once per sensor frame; the 32-bit time of
 * the latest frame tick is the timestamp of the frame read after it. */
#ifndef MOA_FW_CLOCK_H
#define MOA_FW_CLOCK_H

#include <stdbool.h>
#include <stdint.h>

void clock_start(void);
/* Frame ticks since the last call (0 if none; more than 1 means reads fell
 * behind) and the time of the latest one, in ticks (wraps at 2^32). */
uint8_t clock_take_ticks(uint32_t* latest);
/* True if a frame tick is waiting; call with interrupts disabled. */
bool clock_tick_pending(void);

#endif
