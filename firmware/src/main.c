/* moa acquisition firmware: reads N ADNS-3080 sensors once per frame tick,
 * sums K frames per sensor (Kim & Lee's downsampler) and streams one DATA
 * frame per window over the UART in moa serial protocol v1. */
#include <avr/interrupt.h>
#include <avr/sleep.h>
#include <stdbool.h>
#include <stdint.h>

#include "adns3080.h"
#include "board.h"
#include "clock.h"
#include "config.h"
#include "protocol.h"
#include "spi.h"
#include "uart.h"
#include "window.h"

#define N MOA_FW_SENSORS

/* HELLO: 13 fixed bytes and "m1".."m14" (length byte + up to 3 chars). */
#define HELLO_MAX (13u + 4u * N)
#define DATA_LENGTH (8u + 6u * N)
/* Both payloads plus the CRC appended in place. */
#define PAYLOAD_MAX ((HELLO_MAX > DATA_LENGTH ? HELLO_MAX : DATA_LENGTH) + 2u)

static uint8_t payload[PAYLOAD_MAX];
static moa_window_t windows[N];
static bool present[N];
static uint16_t k = MOA_FW_K;
static uint16_t cpi = MOA_FW_CPI;
static uint16_t frames_in_window;
static uint16_t sequence;
static uint32_t window_end_time;
static moa_command_reader_t command_reader;

static void put_u16(uint8_t* p, uint16_t v) {
  p[0] = (uint8_t)v;
  p[1] = (uint8_t)(v >> 8);
}

static void put_u32(uint8_t* p, uint32_t v) {
  put_u16(p, (uint16_t)v);
  put_u16(p + 2, (uint16_t)(v >> 16));
}

static void send_hello(void) {
  payload[0] = MOA_TYPE_HELLO;
  payload[1] = MOA_PROTOCOL_VERSION;
  payload[2] = N;
  put_u16(payload + 3, k);
  put_u16(payload + 5, (uint16_t)MOA_FW_FRAME_HZ);
  put_u16(payload + 7, cpi);
  put_u32(payload + 9, MOA_FW_TICK_HZ);
  uint8_t at = 13;
  for (uint8_t i = 0; i < N; ++i) {
    /* Sensor names m1..mN, as in the robot configuration's example. */
    const uint8_t number = (uint8_t)(i + 1u);
    payload[at++] = number < 10 ? 2 : 3;
    payload[at++] = 'm';
    if (number >= 10) payload[at++] = (uint8_t)('0' + number / 10u);
    payload[at++] = (uint8_t)('0' + number % 10u);
  }
  /* A configuration answer must not be lost: wait for room. */
  protocol_send(payload, at, true);
}

static void start_window(void) {
  for (uint8_t i = 0; i < N; ++i) window_reset(&windows[i]);
  frames_in_window = 0;
}

static void send_data(void) {
  payload[0] = MOA_TYPE_DATA;
  put_u16(payload + 1, sequence);
  put_u32(payload + 3, window_end_time);
  payload[7] = N;
  uint8_t* record = payload + 8;
  for (uint8_t i = 0; i < N; ++i, record += 6) {
    moa_record_t r = {0, 0, 0, MOA_FLAG_NO_SURFACE};
    if (present[i]) r = window_record(&windows[i]);
    put_u16(record, (uint16_t)r.dx);
    put_u16(record + 2, (uint16_t)r.dy);
    record[4] = r.squal;
    record[5] = r.flags;
  }
  /* If the link cannot keep up the frame is dropped rather than the reads
   * delayed; its sequence number is used all the same, so the host counts
   * it as lost. */
  protocol_send(payload, DATA_LENGTH, false);
  ++sequence;
  start_window();
}

/* Counts of different settings must not be summed: a partial window is
 * sent as it is before a change (its timestamp says how long it was). */
static void flush_window(void) {
  if (frames_in_window > 0) send_data();
}

static void read_frame(uint32_t tick_time) {
  for (uint8_t i = 0; i < N; ++i) {
    if (!present[i]) continue;
    adns3080_motion_t m;
    adns3080_motion_burst(i, &m);
    window_add(&windows[i], m.motion, m.dx, m.dy, m.squal, MOA_FW_SQUAL_FLOOR);
  }
  window_end_time = tick_time;
  if (++frames_in_window >= k) send_data();
}

static void apply_cpi(uint16_t value) {
  for (uint8_t i = 0; i < N; ++i) {
    if (present[i]) present[i] = adns3080_set_cpi(i, value);
  }
  cpi = value;
}

static void handle(const moa_command_t* command) {
  switch (command->type) {
    case MOA_TYPE_SET_K:
      if (command->value >= 1 && command->value <= MOA_FW_K_MAX && command->value != k) {
        flush_window();
        k = command->value;
      }
      break;
    case MOA_TYPE_SET_CPI:
      if ((command->value == 400 || command->value == 1600) && command->value != cpi) {
        flush_window();
        apply_cpi(command->value);
      }
      break;
    default:
      break;
  }
  /* Every command is answered with HELLO; a refused value shows as the
   * setting left unchanged. */
  send_hello();
}

/* Sleeps (idle mode: timers and UART keep running) until a frame tick or a
 * received byte needs the main loop. */
static void wait_for_work(void) {
  set_sleep_mode(SLEEP_MODE_IDLE);
  cli();
  while (!clock_tick_pending() && !uart_rx_available()) {
    sleep_enable();
    sei();
    sleep_cpu();
    sleep_disable();
    cli();
  }
  sei();
}

int main(void) {
  uart_init();
  spi_init();
  adns3080_init_bus(N);
  for (uint8_t i = 0; i < N; ++i) present[i] = adns3080_present(i);
  command_reader_reset(&command_reader);
  start_window();
  sei();
  apply_cpi(cpi);
  /* A lone delimiter ends whatever partial frame the host may hold from
   * before a reset, so that the HELLO is not lost with it. */
  while (uart_tx_free() < 1) {
  }
  uart_tx_put(0);
  send_hello();
  clock_start();

  for (;;) {
    wait_for_work();
    while (uart_rx_available()) {
      moa_command_t command;
      if (command_reader_push(&command_reader, uart_rx_get(), &command)) handle(&command);
    }
    uint32_t tick_time;
    if (clock_take_ticks(&tick_time) > 0) read_frame(tick_time);
  }
}
