/* moa serial protocol v1, device side (docs/serial-protocol.md): every
 * frame is COBS(payload || crc16_le(payload)) || 0x00. */
#ifndef MOA_FW_PROTOCOL_H
#define MOA_FW_PROTOCOL_H

#include <stdbool.h>
#include <stdint.h>

#define MOA_PROTOCOL_VERSION 1
#define MOA_TYPE_HELLO 0x01
#define MOA_TYPE_DATA 0x02
#define MOA_TYPE_GYRO 0x03
#define MOA_TYPE_STATUS 0x04
#define MOA_TYPE_SHUTTER 0x05
#define MOA_TYPE_SET_K 0x10
#define MOA_TYPE_SET_CPI 0x11
#define MOA_TYPE_HELLO_REQUEST 0x12

/* Longest command payload plus its CRC (SET_K, SET_CPI: 3 + 2). */
#define MOA_COMMAND_MAX 5

/* CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no xor-out. */
uint16_t crc16_update(uint16_t crc, uint8_t byte);

/* Longest payload the device sends (HELLO or DATA of 14 sensors), and its
 * frame on the wire: CRC, one COBS code byte (payloads stay under 254
 * bytes) and the delimiter. */
#define MOA_PAYLOAD_MAX (8u + 6u * 14u)
#define MOA_FRAME_MAX (MOA_PAYLOAD_MAX + 4u)

/* Sends payload[0..length) as one frame through the UART, waiting for room
 * in the transmit ring. The buffer must have room for two more bytes (the
 * CRC is appended in place). */
void protocol_send(uint8_t* payload, uint8_t length);

/* Incremental command decoder. */
typedef struct {
  uint8_t block[MOA_COMMAND_MAX + 2]; /* COBS block: payload + CRC + codes */
  uint8_t length;
  bool overlong;
} moa_command_reader_t;

typedef struct {
  uint8_t type;
  uint16_t value; /* K or cpi; 0 for HELLO_REQUEST */
} moa_command_t;

void command_reader_reset(moa_command_reader_t* r);
/* Feeds one received byte; true when it completes a well-formed command
 * (good COBS, CRC and length), which is then stored in *out. */
bool command_reader_push(moa_command_reader_t* r, uint8_t byte, moa_command_t* out);

#endif
