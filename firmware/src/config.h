/* Build-time settings of the moa acquisition firmware.
 *
 * Every setting can be overridden with -D on the avr-gcc command line (the
 * CMake function moa_add_firmware does that per build). K and the
 * resolution can also be changed at run time by the host (SET_K, SET_CPI,
 * docs/serial-protocol.md); N, the frame rate and the baud rate cannot. */
#ifndef MOA_FW_CONFIG_H
#define MOA_FW_CONFIG_H

#ifndef F_CPU
#error "F_CPU (the clock in Hz) must be defined"
#endif

#include "sensor.h"

/* The sensor on every chip select (sensor.h): MOA_SENSOR_ADNS3080,
 * _PMW3360, _PMW3389, _PMW3901 or _PAA5100. */
#ifndef MOA_FW_SENSOR
#define MOA_FW_SENSOR MOA_SENSOR_ADNS3080
#endif

/* PMW33xx: whether the build has an SROM image (moa_srom_image.h, made by
 * firmware/CMakeLists.txt from -DMOA_PMW3360_SROM=...). Without one the
 * firmware reports every PMW33xx as "no SROM" and reads none. */
#ifndef MOA_FW_HAVE_SROM
#define MOA_FW_HAVE_SROM 0
#endif

/* N: number of sensors, one chip select each (board.h). */
#ifndef MOA_FW_SENSORS
#define MOA_FW_SENSORS 4
#endif

/* K: sensor frames summed into one DATA frame at start-up. Kim & Lee's
 * downsampler uses K = 12 (their Section V). */
#ifndef MOA_FW_K
#define MOA_FW_K 12
#endif

/* Sensor frames per second: how often every sensor's motion burst is read.
 * This is the FPS of Kim & Lee eq. (50) for the counts the host receives;
 * the ADNS-3080 itself images faster and accumulates between reads. */
#ifndef MOA_FW_FRAME_HZ
#define MOA_FW_FRAME_HZ 1000
#endif

/* Resolution at start-up, counts per inch: ADNS-3080 400 or 1600; PMW3360
 * 100..12000 in steps of 100; PMW3389 50..16000 in steps of 50; 0 for the
 * flow chips, whose counts per inch depend on their height. */
#ifndef MOA_FW_CPI
#define MOA_FW_CPI 1600
#endif

/* UART rate. 500000 is exact at 8 and 16 MHz (U2X, UBRR = 1 or 3) and a
 * standard Linux rate (B500000); see docs/firmware.md for others. */
#ifndef MOA_FW_BAUD
#define MOA_FW_BAUD 500000UL
#endif

/* SQUAL below this marks a window "lift or no surface" (flags bit 1). */
#ifndef MOA_FW_SQUAL_FLOOR
#define MOA_FW_SQUAL_FLOOR 16
#endif

#define MOA_FW_K_MAX 1000u

/* The gyro (gyro.h) on the TWI bus, whose pins are the chip selects of
 * sensors 13 and 14: on by default up to 12 sensors. A build with it still
 * runs without a gyro connected (no GYRO frames then). */
#ifndef MOA_FW_GYRO
#define MOA_FW_GYRO (MOA_FW_SENSORS <= 12)
#endif

/* Timestamp ticks: Timer1 with prescaler 8. */
#define MOA_FW_TICK_HZ (F_CPU / 8UL)
#define MOA_FW_FRAME_TICKS (MOA_FW_TICK_HZ / MOA_FW_FRAME_HZ)

_Static_assert(MOA_FW_SENSORS >= 1 && MOA_FW_SENSORS <= 14,
               "MOA_FW_SENSORS: 1..14 (chip-select pins available, board.h)");
_Static_assert(MOA_FW_K >= 1 && MOA_FW_K <= MOA_FW_K_MAX, "MOA_FW_K: 1..1000");
#if MOA_FW_SENSOR == MOA_SENSOR_ADNS3080
_Static_assert(MOA_FW_CPI == 400 || MOA_FW_CPI == 1600, "MOA_FW_CPI: 400 or 1600");
#elif MOA_FW_SENSOR == MOA_SENSOR_PMW3360
_Static_assert(MOA_FW_CPI >= 100 && MOA_FW_CPI <= 12000 && MOA_FW_CPI % 100 == 0,
               "MOA_FW_CPI: 100..12000 in steps of 100 for the PMW3360");
#elif MOA_FW_SENSOR == MOA_SENSOR_PMW3389
_Static_assert(MOA_FW_CPI >= 50 && MOA_FW_CPI <= 16000 && MOA_FW_CPI % 50 == 0,
               "MOA_FW_CPI: 50..16000 in steps of 50 for the PMW3389");
#elif MOA_FW_SENSOR == MOA_SENSOR_PMW3901 || MOA_FW_SENSOR == MOA_SENSOR_PAA5100
_Static_assert(MOA_FW_CPI == 0, "MOA_FW_CPI: 0 for a flow chip (its cpi depends on height)");
#else
#error "MOA_FW_SENSOR: one of the MOA_SENSOR_* of sensor.h"
#endif

/* Sensors whose burst has a shutter: their windows' longest exposure goes
 * out in a SHUTTER frame after each DATA frame. */
#define MOA_FW_HAS_SHUTTER (MOA_FW_SENSOR != MOA_SENSOR_ADNS3080)

/* Silent reads in a row (sensor.h, MOA_SAMPLE_SILENT) after which a sensor
 * that answered at start counts as stopped: no more reads until reset. */
#define MOA_FW_SILENT_READS 3
_Static_assert(MOA_FW_TICK_HZ % MOA_FW_FRAME_HZ == 0,
               "MOA_FW_FRAME_HZ must divide F_CPU/8 so that frames are a whole number of ticks");
_Static_assert(MOA_FW_FRAME_TICKS >= 2 && MOA_FW_FRAME_TICKS <= 65536UL,
               "MOA_FW_FRAME_HZ out of Timer1's range");
_Static_assert(MOA_FW_FRAME_HZ <= 65535UL, "MOA_FW_FRAME_HZ must fit the HELLO's u16");
_Static_assert(!MOA_FW_GYRO || MOA_FW_SENSORS <= 12,
               "MOA_FW_GYRO: the TWI pins are the chip selects of sensors 13 and 14");

/* Time budget of one frame (docs/firmware.md, rates): a motion burst costs
 * the sensor's 75 us wait plus 5 bytes at 2 MHz (25 us), and about 480 CPU
 * cycles of code and of UART interrupts that run meanwhile; the frame
 * interrupt takes about 300 cycles to reach the first read. All N reads
 * must fit 90 % of the frame period (measured in simavr by the firmware
 * tests, which also check that no tick is missed). */
#if MOA_FW_SENSOR == MOA_SENSOR_ADNS3080
#define MOA_FW_READ_NS_PER_SENSOR (100000ULL + 480ULL * 1000000000ULL / F_CPU)
#elif MOA_FW_SENSOR == MOA_SENSOR_PMW3360 || MOA_FW_SENSOR == MOA_SENSOR_PMW3389
/* 1 + 4 + 35 + 12 x 4 + 1 us of bus, and the code of 13 bytes with the
 * UART interrupts meanwhile (measured in simavr: 146 us a sensor at 16 MHz). */
#define MOA_FW_READ_NS_PER_SENSOR (89000ULL + 1000ULL * 1000000000ULL / F_CPU)
#else
/* 1 + 4 + 50 + 12 x 4 + 1 us of bus, and the code of 13 bytes. */
#define MOA_FW_READ_NS_PER_SENSOR (104000ULL + 900ULL * 1000000000ULL / F_CPU)
#endif
/* The gyro read: START, SLA+W, register, repeated START, SLA+R, two bytes,
 * about 47 SCL periods at 400 kHz (118 us) and up to 2 us of code per step;
 * a bus that hangs costs at most one step's 50 us timeout more (twi.h). */
#define MOA_FW_GYRO_READ_NS (MOA_FW_GYRO ? 190000ULL : 0ULL)
#define MOA_FW_FRAME_READ_NS                                                     \
  (MOA_FW_SENSORS * MOA_FW_READ_NS_PER_SENSOR + 300ULL * 1000000000ULL / F_CPU + \
   MOA_FW_GYRO_READ_NS)
_Static_assert(MOA_FW_FRAME_READ_NS * 10ULL <= 9ULL * 1000000000ULL / MOA_FW_FRAME_HZ,
               "MOA_FW_SENSORS reads do not fit one frame at MOA_FW_FRAME_HZ: lower the rate");

#endif
