/* moa acquisition firmware: reads N motion sensors (sensor.h: ADNS-3080,
 * PMW3360, PMW3389, PMW3901 or PAA5100, one kind per build) (and the z rate of
 * an MPU-6050 gyro, if one answers) once per frame tick, sums K frames per
 * sensor (Kim & Lee's downsampler, their Section V) and streams one DATA
 * frame per window, followed by the window's SHUTTER frame (PixArt chips)
 * and GYRO frame, and a STATUS frame after each HELLO, over the
 * UART in moa serial protocol v1 (docs/serial-protocol.md).
 *
 * Two contexts share the work. The frame interrupt (clock.h) reads the
 * sensors and closes windows: hard real time, it keeps to the clock. The
 * main loop encodes and sends closed windows and answers commands: it may
 * take as long as K frames, and is preempted by the reads. Closed windows
 * pass from one to the other through two slots (see close_window). */
#include <avr/interrupt.h>
#include <avr/sleep.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>
#include <util/atomic.h>
#include <util/delay.h>

#include "board.h"
#include "clock.h"
#include "config.h"
#include "gyro.h"
#include "protocol.h"
#include "sensor.h"
#include "spi.h"
#include "uart.h"
#include "window.h"

#define N MOA_FW_SENSORS

/* HELLO: 13 fixed bytes and "m1".."m14" (length byte + up to 3 chars). */
#define HELLO_MAX (13u + 4u * N)
#define DATA_LENGTH (8u + 6u * N)
#define GYRO_LENGTH 12u
#define STATUS_LENGTH (2u + 2u * N)
#define SHUTTER_LENGTH (4u + 2u * N)
/* Both payloads plus the CRC appended in place (GYRO's is shorter). */
#define PAYLOAD_MAX ((HELLO_MAX > DATA_LENGTH ? HELLO_MAX : DATA_LENGTH) + 2u)
_Static_assert(GYRO_LENGTH + 2u <= PAYLOAD_MAX && STATUS_LENGTH + 2u <= PAYLOAD_MAX &&
                   SHUTTER_LENGTH + 2u <= PAYLOAD_MAX,
               "the GYRO, STATUS and SHUTTER payloads must fit the buffer");
_Static_assert(HELLO_MAX <= MOA_PAYLOAD_MAX && DATA_LENGTH <= MOA_PAYLOAD_MAX,
               "payload longer than protocol.h allows for");
_Static_assert(MOA_FRAME_MAX < MOA_UART_TX_SIZE, "a whole frame must fit the transmit ring");

/* The gyro's share of a window: the z rates of `n` frames summed (raw LSB;
 * K <= 1000 frames of |z| <= 32768 fit 26 bits). */
typedef struct {
  int32_t sum;
  uint16_t n;
  uint8_t flags; /* bit 0: a sample at full scale */
} gyro_window_t;

/* A closed window on its way from the frame interrupt to the main loop. */
typedef struct {
  uint16_t sequence;
  uint32_t time;
  moa_window_t windows[N];
  gyro_window_t gyro;
} closed_window_t;

/* Settings; written by the main loop only while reads are paused. */
static uint16_t k = MOA_FW_K;
static uint16_t cpi = MOA_FW_CPI;
/* What each chip select holds (sensor.h); only MOA_SENSOR_OK ones are read.
 * The frame interrupt may turn OK into STOPPED (then status_changed). */
static moa_sensor_status_t status[N];
static volatile bool status_changed;
static uint8_t silent_reads[N];
/* The gyro answered at start and has not failed since: a failed read (a
 * NACK or a bus timeout) turns it off until reset, so that a broken bus
 * costs one timeout, not one per frame. */
static volatile bool gyro_on;

/* Frame interrupt state (the main loop touches it only while paused). */
static moa_window_t windows[N];
static gyro_window_t gyro_window;
static uint16_t frames_in_window;
static uint32_t last_frame_time;
static uint16_t next_sequence;
static volatile bool paused = true;

/* Slot states: the interrupt fills an EMPTY slot or adds to a READY one;
 * the main loop turns READY into SENDING while it reads the slot, then
 * EMPTY. At most one slot is READY, so frames keep their order. */
enum { SLOT_EMPTY, SLOT_READY, SLOT_SENDING };
static closed_window_t slots[2];
static volatile uint8_t slot_state[2];

/* Main loop state. */
static uint8_t payload[PAYLOAD_MAX];
static moa_command_reader_t command_reader;

static void put_u16(uint8_t* p, uint16_t v) {
  p[0] = (uint8_t)v;
  p[1] = (uint8_t)(v >> 8);
}

static void put_u32(uint8_t* p, uint32_t v) {
  put_u16(p, (uint16_t)v);
  put_u16(p + 2, (uint16_t)(v >> 16));
}

static void start_window(void) {
  for (uint8_t i = 0; i < N; ++i) window_reset(&windows[i]);
  gyro_window.sum = 0;
  gyro_window.n = 0;
  gyro_window.flags = 0;
  frames_in_window = 0;
}

/* Hands the window to the main loop. If the previous one has not been
 * picked up yet (the link or the main loop is slower than the data), this
 * one is added to it rather than lost: that frame then covers more than K
 * sensor frames, and its timestamp says how long. Called from the frame
 * interrupt, or from the main loop while reads are paused. */
static void close_window(void) {
  uint8_t slot = slot_state[0] == SLOT_READY ? 0 : 1;
  if (slot_state[slot] == SLOT_READY) {
    for (uint8_t i = 0; i < N; ++i) window_merge(&slots[slot].windows[i], &windows[i]);
    gyro_window_t* g = &slots[slot].gyro;
    g->sum += gyro_window.sum;
    g->n = (uint16_t)(g->n + gyro_window.n);
    g->flags |= gyro_window.flags;
  } else {
    slot = slot_state[0] == SLOT_EMPTY ? 0 : 1;
    slots[slot].sequence = next_sequence++;
    memcpy(slots[slot].windows, windows, sizeof windows);
    slots[slot].gyro = gyro_window;
  }
  slots[slot].time = last_frame_time;
  slot_state[slot] = SLOT_READY;
  start_window();
}

void frame_tick(uint32_t tick_time) {
  if (paused) return;
  for (uint8_t i = 0; i < N; ++i) {
    if (status[i].state != MOA_SENSOR_OK) continue;
    moa_sample_t sample;
    sensor_read(i, &sample);
    window_add(&windows[i], &sample, MOA_FW_SQUAL_FLOOR);
    if (!(sample.flags & MOA_SAMPLE_SILENT)) {
      silent_reads[i] = 0;
    } else if (++silent_reads[i] >= MOA_FW_SILENT_READS) {
      status[i].state = MOA_SENSOR_STOPPED;
      status_changed = true;
    }
  }
#if MOA_FW_GYRO
  /* After the mice, so that their reads keep to the clock. */
  if (gyro_on) {
    int16_t z;
    if (gyro_read_z(&z)) {
      gyro_window.sum += z;
      ++gyro_window.n;
      if (z == INT16_MAX || z == INT16_MIN) gyro_window.flags |= MOA_GYRO_SATURATED;
    } else {
      gyro_on = false;
    }
  }
#endif
  last_frame_time = tick_time;
  if (++frames_in_window >= k) close_window();
}

static void send_hello(void) {
  payload[0] = MOA_TYPE_HELLO;
  payload[1] = MOA_PROTOCOL_VERSION;
  payload[2] = N;
  put_u16(payload + 3, k);
  put_u16(payload + 5, (uint16_t)MOA_FW_FRAME_HZ);
  put_u16(payload + 7, cpi); /* 0 for the flow chips: not given */
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
  protocol_send(payload, at);
}

/* Sends the closed window, if there is one. */
static void send_ready(void) {
  uint8_t slot = 2;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    for (uint8_t s = 0; s < 2; ++s) {
      if (slot_state[s] == SLOT_READY) slot = s;
    }
    if (slot < 2) slot_state[slot] = SLOT_SENDING;
  }
  if (slot == 2) return;
  const closed_window_t* w = &slots[slot];
  payload[0] = MOA_TYPE_DATA;
  put_u16(payload + 1, w->sequence);
  put_u32(payload + 3, w->time);
  payload[7] = N;
  uint8_t* record = payload + 8;
#if MOA_FW_HAS_SHUTTER
  uint16_t shutters[N];
#endif
  for (uint8_t i = 0; i < N; ++i, record += 6) {
    /* A sensor that stopped keeps the records of its last windows (their
     * reads happened), then reports no surface and the fault. */
    moa_record_t r = {0, 0, 0, MOA_FLAG_NO_SURFACE, 0};
    if (status[i].state == MOA_SENSOR_STOPPED) r.flags |= MOA_FLAG_FAULT;
    if (status[i].state == MOA_SENSOR_OK || w->windows[i].min_squal != 0xFF ||
        w->windows[i].flags != 0) {
      r = window_record(&w->windows[i]);
    }
#if MOA_FW_HAS_SHUTTER
    shutters[i] = r.shutter;
#endif
    put_u16(record, (uint16_t)r.dx);
    put_u16(record + 2, (uint16_t)r.dy);
    record[4] = r.squal;
    record[5] = r.flags;
  }
  const gyro_window_t gyro = w->gyro;
  const uint16_t sequence = w->sequence;
  slot_state[slot] = SLOT_EMPTY;
  protocol_send(payload, DATA_LENGTH);
#if MOA_FW_HAS_SHUTTER
  payload[0] = MOA_TYPE_SHUTTER;
  put_u16(payload + 1, sequence);
  payload[3] = N;
  for (uint8_t i = 0; i < N; ++i) put_u16(payload + 4 + 2 * i, shutters[i]);
  protocol_send(payload, SHUTTER_LENGTH);
#endif
  /* The rate over the same window, if the gyro gave any sample in it. */
  if (gyro.n == 0) return;
  payload[0] = MOA_TYPE_GYRO;
  put_u16(payload + 1, sequence);
  put_u32(payload + 3, (uint32_t)gyro.sum);
  put_u16(payload + 7, gyro.n);
  put_u16(payload + 9, MOA_GYRO_LSB_PER_DPS_X10);
  payload[11] = gyro.flags;
  protocol_send(payload, GYRO_LENGTH);
}

/* Stops the reads between two frames, so that the main loop may use the
 * SPI bus and the windows. The main loop only runs while the frame
 * interrupt does not, so no read is ever cut in half. Ticks keep counting. */
static void pause_reads(void) {
  paused = true;
  /* t_BEXIT: a burst of the last sensor may have ended just now. */
  _delay_us(4);
}

static void resume_reads(void) { paused = false; }

/* Counts of different settings must not be summed: a partial window goes
 * out as it is before a change (its timestamp says how long it was). */
static void flush_window(void) {
  send_ready();
  if (frames_in_window > 0) {
    close_window();
    send_ready();
  }
}

/* STATUS: what every chip select holds; after each HELLO and whenever a
 * sensor's state changes. */
static void send_status(void) {
  status_changed = false;
  payload[0] = MOA_TYPE_STATUS;
  payload[1] = N;
  for (uint8_t i = 0; i < N; ++i) {
    payload[2 + 2 * i] = status[i].state;
    payload[3 + 2 * i] = status[i].detail;
  }
  protocol_send(payload, STATUS_LENGTH);
}

static void apply_cpi(uint16_t value) {
  for (uint8_t i = 0; i < N; ++i) {
    if (status[i].state == MOA_SENSOR_OK && !sensor_set_cpi(i, value)) {
      status[i].state = MOA_SENSOR_CPI_REFUSED;
      status_changed = true;
    }
  }
  cpi = value;
}

static void handle(const moa_command_t* command) {
  const uint16_t value = command->value;
  switch (command->type) {
    case MOA_TYPE_SET_K:
      if (value >= 1 && value <= MOA_FW_K_MAX && value != k) {
        pause_reads();
        flush_window();
        k = value;
        resume_reads();
      }
      break;
    case MOA_TYPE_SET_CPI:
      if (sensor_cpi_valid(value) && value != cpi) {
        pause_reads();
        flush_window();
        apply_cpi(value);
        resume_reads();
      }
      break;
    default:
      break;
  }
  /* Every command is answered with HELLO (and STATUS); a refused value
   * shows as the setting left unchanged. */
  send_hello();
  send_status();
}

/* Sleeps (idle mode: timers and UART keep running) until a closed window
 * or a received byte needs the main loop. */
static void wait_for_work(void) {
  /* The sleep mode bits are left at their reset value, which is idle. */
  cli();
  while (slot_state[0] != SLOT_READY && slot_state[1] != SLOT_READY && !uart_rx_available() &&
         !status_changed) {
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
  sensor_init_bus(N);
  for (uint8_t i = 0; i < N; ++i) status[i] = sensor_start(i);
#if MOA_FW_GYRO
  gyro_on = gyro_init();
#endif
  command_reader_reset(&command_reader);
  start_window();
  apply_cpi(cpi);
  sei();
  /* A lone delimiter ends whatever partial frame the host may hold from
   * before a reset, so that the HELLO is not lost with it. */
  static const uint8_t delimiter = 0;
  uart_tx_write(&delimiter, 1);
  send_hello();
  send_status();
  clock_start();
  resume_reads();

  for (;;) {
    wait_for_work();
    while (uart_rx_available()) {
      moa_command_t command;
      if (command_reader_push(&command_reader, uart_rx_get(), &command)) handle(&command);
    }
    send_ready();
    if (status_changed) send_status();
  }
}
