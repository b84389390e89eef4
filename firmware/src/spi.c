#include "spi.h"

#include <avr/io.h>

#include "config.h"

/* The fastest AVR divider that keeps SCLK at or below 2 MHz. */
#define MOA_SPI_MAX_HZ 2000000UL
#if F_CPU / 2 <= MOA_SPI_MAX_HZ
#define MOA_SPI_SPCR 0
#define MOA_SPI_2X 1
#elif F_CPU / 4 <= MOA_SPI_MAX_HZ
#define MOA_SPI_SPCR 0
#define MOA_SPI_2X 0
#elif F_CPU / 8 <= MOA_SPI_MAX_HZ
#define MOA_SPI_SPCR _BV(SPR0)
#define MOA_SPI_2X 1
#elif F_CPU / 16 <= MOA_SPI_MAX_HZ
#define MOA_SPI_SPCR _BV(SPR0)
#define MOA_SPI_2X 0
#else
#define MOA_SPI_SPCR _BV(SPR1)
#define MOA_SPI_2X 1
#endif

void spi_init(void) {
  /* SS (PB2) is an output (chip select 0), so a low level on it can never
   * drop the SPI out of master mode. */
  DDRB |= _BV(PB2) | _BV(PB3) | _BV(PB5);
  DDRB &= (uint8_t)~_BV(PB4);
  SPCR = _BV(SPE) | _BV(MSTR) | _BV(CPOL) | _BV(CPHA) | MOA_SPI_SPCR;
  SPSR = MOA_SPI_2X ? _BV(SPI2X) : 0;
}

uint8_t spi_transfer(uint8_t out) {
  SPDR = out;
  while (!(SPSR & _BV(SPIF))) {
  }
  return SPDR;
}
