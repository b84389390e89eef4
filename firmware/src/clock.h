/* Frame clock and timestamps. Timer1 counts F_CPU/8 ticks (MOA_FW_TICK_HZ,
 * declared in HELLO) and fires once per sensor frame. The sensors are read
 * in that interrupt, so that the reads keep to the clock whatever the main
 * loop is doing (encoding, sending, answering commands). */
#ifndef MOA_FW_CLOCK_H
#define MOA_FW_CLOCK_H

#include <stdint.h>

/* Starts the frame clock: from now on frame_tick() runs every frame. */
void clock_start(void);

/* Called from the timer interrupt, with interrupts enabled again (the UART
 * keeps being served), never nested: a tick that arrives while the previous
 * one is still being handled only advances the time. `tick_time` is the
 * time of this tick in ticks (wraps at 2^32). Defined by the application. */
void frame_tick(uint32_t tick_time);

#endif
