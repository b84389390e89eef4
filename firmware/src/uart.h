/* Interrupt-driven UART, 8N1. Transmission goes through a ring buffer so
 * that sending a frame never stalls the sensor reads; reception fills a
 * small ring read by the main loop. */
#ifndef MOA_FW_UART_H
#define MOA_FW_UART_H

#include <stdbool.h>
#include <stdint.h>

/* Large enough for the longest frame (HELLO or DATA of 14 sensors). */
#define MOA_UART_TX_SIZE 128u
#define MOA_UART_RX_SIZE 32u

void uart_init(void);
/* Queues n bytes (n < MOA_UART_TX_SIZE), first waiting until the ring has
 * room for all of them: a frame is never interleaved or cut. */
void uart_tx_write(const uint8_t* bytes, uint8_t n);
bool uart_rx_available(void);
uint8_t uart_rx_get(void);

#endif
