/* SPI master for the ADNS-3080: mode 3 (clock idles high, data sampled on
 * the rising edge), MSB first, clock at most 2 MHz (the sensor's f_SCLK). */
#ifndef MOA_FW_SPI_H
#define MOA_FW_SPI_H

#include <stdint.h>

void spi_init(void);
uint8_t spi_transfer(uint8_t out);

#endif
