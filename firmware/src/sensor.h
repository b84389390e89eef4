/* The motion sensor on every chip select: one driver per build, chosen by
 * MOA_FW_SENSOR (config.h, and the CMake build table). Every driver gives
 * the main loop the same samples, so the serial frames are the same. */
#ifndef MOA_FW_SENSOR_H
#define MOA_FW_SENSOR_H

#include <stdbool.h>
#include <stdint.h>

#define MOA_SENSOR_ADNS3080 1
#define MOA_SENSOR_PMW3360 2
#define MOA_SENSOR_PMW3389 3
#define MOA_SENSOR_PMW3901 4
#define MOA_SENSOR_PAA5100 5

/* One read of one sensor (one motion burst). */
#define MOA_SAMPLE_OVERFLOW 0x01 /* the chip's motion overflow bit */
#define MOA_SAMPLE_LIFT 0x02     /* the chip says it is lifted (PMW33xx Lift_Stat) */
#define MOA_SAMPLE_REJECTED 0x04 /* the sensor's quality rule refuses the counts */
#define MOA_SAMPLE_SILENT 0x08   /* every burst byte 0x00 or every one 0xFF: nobody answered */

typedef struct {
  int16_t dx; /* counts, the sensor's own frame */
  int16_t dy;
  uint16_t shutter; /* exposure, the chip's units (0 where it has none) */
  uint8_t squal;
  uint8_t flags; /* MOA_SAMPLE_* */
} moa_sample_t;

/* What start-up (or a later read) found on a chip select; sent to the host
 * in STATUS frames (docs/serial-protocol.md). */
enum {
  MOA_SENSOR_OK = 0,
  MOA_SENSOR_NO_ANSWER = 1,     /* product ID read 0x00 or 0xFF */
  MOA_SENSOR_WRONG_ID = 2,      /* another part; detail: the ID it gave */
  MOA_SENSOR_NO_SROM = 3,       /* the build has no SROM image (PMW33xx) */
  MOA_SENSOR_SROM_REJECTED = 4, /* SROM_ID or the CRC test failed; detail: SROM_ID */
  MOA_SENSOR_STOPPED = 5,       /* it answered at start, then its bursts went silent */
  MOA_SENSOR_CPI_REFUSED = 6,   /* the resolution did not read back */
};

typedef struct {
  uint8_t state;
  uint8_t detail;
} moa_sensor_status_t;

/* Chip selects as outputs (deselected), the shared reset line, the power-up
 * reset of every chip and the wait after it. */
void sensor_init_bus(uint8_t sensors);
/* Product ID, SROM (PMW33xx), init registers; MOA_SENSOR_OK when usable. */
moa_sensor_status_t sensor_start(uint8_t sensor);
/* Whether `cpi` is a resolution this sensor can be set to. */
bool sensor_cpi_valid(uint16_t cpi);
/* Sets the resolution and reads it back; false if the chip did not take it. */
bool sensor_set_cpi(uint8_t sensor, uint16_t cpi);
/* One motion burst. */
void sensor_read(uint8_t sensor, moa_sample_t* out);

/* Chip-select helpers for the drivers (cs.c). */
void cs_init(uint8_t sensors);
void cs_low(uint8_t sensor);
void cs_high(uint8_t sensor);

/* True if n bytes are all 0x00 or all 0xFF (an undriven or dead MISO). */
bool bytes_silent(const uint8_t* bytes, uint8_t n);

#endif
