#include "uart.h"

#include <avr/interrupt.h>
#include <util/atomic.h>

#include "board.h"
#include "config.h"

/* Double speed (U2X): the divider is F_CPU / (8 baud) - 1, rounded. */
#define MOA_UBRR ((F_CPU + 4UL * MOA_FW_BAUD) / (8UL * MOA_FW_BAUD) - 1UL)
#define MOA_BAUD_ACTUAL (F_CPU / (8UL * (MOA_UBRR + 1UL)))
#define MOA_BAUD_ERROR_PERMILLE                                      \
  ((MOA_BAUD_ACTUAL > MOA_FW_BAUD ? MOA_BAUD_ACTUAL - MOA_FW_BAUD    \
                                  : MOA_FW_BAUD - MOA_BAUD_ACTUAL) * \
   1000UL / MOA_FW_BAUD)
/* 8N1 tolerates about 4.5 % between the two ends together; keep our share
 * at 2.1 % or less (115200 at 16 MHz is the common worst accepted case). */
_Static_assert(MOA_BAUD_ERROR_PERMILLE <= 21, "MOA_FW_BAUD cannot be made within 2.1 % from F_CPU");
_Static_assert(MOA_UBRR <= 4095UL, "MOA_FW_BAUD too slow for UBRR");

_Static_assert((MOA_UART_TX_SIZE & (MOA_UART_TX_SIZE - 1u)) == 0, "power of two");
_Static_assert((MOA_UART_RX_SIZE & (MOA_UART_RX_SIZE - 1u)) == 0, "power of two");

static volatile uint8_t tx_buf[MOA_UART_TX_SIZE];
static volatile uint8_t tx_head; /* written by the main loop */
static volatile uint8_t tx_tail; /* written by the UDRE interrupt */
static volatile uint8_t rx_buf[MOA_UART_RX_SIZE];
static volatile uint8_t rx_head; /* written by the RX interrupt */
static volatile uint8_t rx_tail; /* written by the main loop */

void uart_init(void) {
  /* U2X before the divider: simavr derives the byte time when UBRRL is
   * written (the hardware does not care about the order). */
  MOA_UCSRA = _BV(MOA_U2X);
  MOA_UBRRH = (uint8_t)(MOA_UBRR >> 8);
  MOA_UBRRL = (uint8_t)MOA_UBRR;
  /* Frame format stays at the reset default, 8N1, on both MCUs. */
  MOA_UCSRB = _BV(MOA_RXEN) | _BV(MOA_TXEN) | _BV(MOA_RXCIE);
}

static uint8_t tx_free(void) {
  const uint8_t free_slots = (uint8_t)(tx_tail - tx_head - 1);
  return (uint8_t)(free_slots & (MOA_UART_TX_SIZE - 1u));
}

void uart_tx_write(const uint8_t* bytes, uint8_t n) {
  while (tx_free() < n) {
  }
  uint8_t head = tx_head;
  for (uint8_t i = 0; i < n; ++i) {
    tx_buf[head] = bytes[i];
    head = (uint8_t)((head + 1u) & (MOA_UART_TX_SIZE - 1u));
  }
  tx_head = head;
  MOA_UCSRB |= _BV(MOA_UDRIE);
}

bool uart_rx_available(void) { return rx_head != rx_tail; }

uint8_t uart_rx_get(void) {
  const uint8_t tail = rx_tail;
  const uint8_t byte = rx_buf[tail];
  rx_tail = (uint8_t)((tail + 1u) & (MOA_UART_RX_SIZE - 1u));
  return byte;
}

ISR(MOA_UART_UDRE_VECT) {
  const uint8_t tail = tx_tail;
  if (tail == tx_head) {
    MOA_UCSRB &= (uint8_t)~_BV(MOA_UDRIE);
    return;
  }
  MOA_UDR = tx_buf[tail];
  tx_tail = (uint8_t)((tail + 1u) & (MOA_UART_TX_SIZE - 1u));
}

ISR(MOA_UART_RX_VECT) {
  const uint8_t byte = MOA_UDR;
  const uint8_t next = (uint8_t)((rx_head + 1u) & (MOA_UART_RX_SIZE - 1u));
  /* A full ring drops the byte; the command it belonged to then fails its
   * CRC and is ignored, which the host sees as a missing HELLO answer. */
  if (next != rx_tail) {
    rx_buf[rx_head] = byte;
    rx_head = next;
  }
}
