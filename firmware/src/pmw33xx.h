/* PixArt PMW3360DM-T2QU and PMW3389DM-T3QU (PMW3360 data sheet v1.50; the
 * PMW3389's shares its serial port, power-up and SROM download):
 * SPI mode 3, f_SCLK <= 2 MHz, and between bytes
 *   t_SRAD        160 us  read: address to data
 *   t_SRAD_MOTBR   35 us  Motion_Burst: address to first data byte
 *   t_SWW, t_SWR  180 us  after a write, before the next write or read
 *   t_SRW, t_SRR   20 us  after a read, before the next command
 *   t_SCLK-NCS     35 us  last bit of a write to NCS high (120 ns for reads)
 *   t_BEXIT       500 ns  NCS high after a burst
 *   power-up      50 ms   after Power_Up_Reset (0x5A to 0x3A)
 *   SROM_Enable   10 ms   after 0x1D, before 0x18; after 0x15 (CRC test)
 *   SROM load     15 us   between the bytes of SROM_Load_Burst
 *                 200 us  NCS high after the load, before SROM_ID
 * Motion: bit 7 MOT, bit 3 Lift_Stat; bits 6:5 reserved (0). */
#ifndef MOA_FW_PMW33XX_H
#define MOA_FW_PMW33XX_H

#define PMW33XX_PRODUCT_ID 0x00
#define PMW33XX_MOTION 0x02
#define PMW33XX_RESOLUTION_L 0x0E /* PMW3389: cpi / 50, low byte */
#define PMW33XX_CONFIG1 0x0F      /* PMW3360: cpi / 100 - 1; PMW3389: Resolution_H */
#define PMW33XX_CONFIG2 0x10      /* bit 5 Rest_En */
#define PMW33XX_SROM_ENABLE 0x13
#define PMW33XX_DATA_OUT_LOWER 0x25
#define PMW33XX_DATA_OUT_UPPER 0x26
#define PMW33XX_SROM_ID 0x2A
#define PMW33XX_POWER_UP_RESET 0x3A
#define PMW33XX_INVERSE_PRODUCT_ID 0x3F
#define PMW33XX_MOTION_BURST 0x50
#define PMW33XX_SROM_LOAD_BURST 0x62

#define PMW33XX_RESET_VALUE 0x5A
#define PMW33XX_SROM_INIT 0x1D
#define PMW33XX_SROM_START 0x18
#define PMW33XX_SROM_CRC 0x15
#define PMW33XX_CRC_OK 0xBEEFu /* Data_Out_Upper:Lower after the CRC test */
#define PMW33XX_MOTION_MOT 0x80
#define PMW33XX_MOTION_LIFT 0x08
#define PMW33XX_BURST_LENGTH 12

#define PMW3360_PRODUCT_ID_VALUE 0x42
#define PMW3389_PRODUCT_ID_VALUE 0x47

#endif
