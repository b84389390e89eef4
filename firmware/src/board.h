/* Pins and the register names that differ between the ATmega328P and the
 * ATmega8 (same package pinout for SPI, UART and the ports used here).
 *
 * Pinout (Arduino Uno/Nano names in brackets), docs/firmware.md:
 *   SPI  SCK PB5 [D13], MISO PB4 [D12], MOSI PB3 [D11]
 *   UART TXD PD1 [D1], RXD PD0 [D0]
 *   RESET of all sensors, active high: PD2 [D2]
 *   chip select of sensor i, active low: CS_PINS[i] below. */
#ifndef MOA_FW_BOARD_H
#define MOA_FW_BOARD_H

#include <avr/io.h>
#include <stdint.h>

#if defined(__AVR_ATmega8__)
#define MOA_UCSRA UCSRA
#define MOA_UCSRB UCSRB
#define MOA_UBRRL UBRRL
#define MOA_UBRRH UBRRH
#define MOA_UDR UDR
#define MOA_U2X U2X
#define MOA_RXEN RXEN
#define MOA_TXEN TXEN
#define MOA_RXCIE RXCIE
#define MOA_UDRIE UDRIE
#define MOA_UART_RX_VECT USART_RXC_vect
#define MOA_UART_UDRE_VECT USART_UDRE_vect
#define MOA_TIMSK1 TIMSK
#elif defined(__AVR_ATmega328P__) || defined(__AVR_ATmega328__) || defined(__AVR_ATmega168__) || \
    defined(__AVR_ATmega88__)
#define MOA_UCSRA UCSR0A
#define MOA_UCSRB UCSR0B
#define MOA_UBRRL UBRR0L
#define MOA_UBRRH UBRR0H
#define MOA_UDR UDR0
#define MOA_U2X U2X0
#define MOA_RXEN RXEN0
#define MOA_TXEN TXEN0
#define MOA_RXCIE RXCIE0
#define MOA_UDRIE UDRIE0
#define MOA_UART_RX_VECT USART_RX_vect
#define MOA_UART_UDRE_VECT USART_UDRE_vect
#define MOA_TIMSK1 TIMSK1
#else
#error "moa firmware: unsupported MCU (ATmega328P, ATmega8)"
#endif

/* RESET line shared by all sensors. */
#define MOA_RESET_PORT PORTD
#define MOA_RESET_DDR DDRD
#define MOA_RESET_BIT PD2

/* Chip selects, in the order of the sensors in HELLO and DATA. PB2 is the
 * SPI SS pin: as an output it keeps the SPI in master mode. */
typedef struct {
  volatile uint8_t* port;
  volatile uint8_t* ddr;
  uint8_t mask;
} moa_pin_t;

/* clang-format off */
#define MOA_CS_PIN_TABLE {                                 \
    {&PORTB, &DDRB, _BV(PB2)}, /* sensor 1:  D10 */         \
    {&PORTB, &DDRB, _BV(PB1)}, /* sensor 2:  D9  */         \
    {&PORTB, &DDRB, _BV(PB0)}, /* sensor 3:  D8  */         \
    {&PORTD, &DDRD, _BV(PD7)}, /* sensor 4:  D7  */         \
    {&PORTD, &DDRD, _BV(PD6)}, /* sensor 5:  D6  */         \
    {&PORTD, &DDRD, _BV(PD5)}, /* sensor 6:  D5  */         \
    {&PORTD, &DDRD, _BV(PD4)}, /* sensor 7:  D4  */         \
    {&PORTD, &DDRD, _BV(PD3)}, /* sensor 8:  D3  */         \
    {&PORTC, &DDRC, _BV(PC0)}, /* sensor 9:  A0  */         \
    {&PORTC, &DDRC, _BV(PC1)}, /* sensor 10: A1  */         \
    {&PORTC, &DDRC, _BV(PC2)}, /* sensor 11: A2  */         \
    {&PORTC, &DDRC, _BV(PC3)}, /* sensor 12: A3  */         \
    {&PORTC, &DDRC, _BV(PC4)}, /* sensor 13: A4  */         \
    {&PORTC, &DDRC, _BV(PC5)}, /* sensor 14: A5  */         \
  }
/* clang-format on */

#endif
