#ifndef PSMAT_IMU_BNO055_H
#define PSMAT_IMU_BNO055_H
#include <stdint.h>

#include "i2c_soft.h"

#define BNO055_ADDR_A 0x28u /* COM3 low */
#define BNO055_ADDR_B 0x29u /* COM3 high */
#define BNO055_BOOT_MS 650u

/* Checks the chip ID and starts NDOF fusion with angles in degrees; 0 on success. */
int bno055_init(const i2c_bus *b, uint8_t addr);
/* heading, roll, pitch in degrees (1/16 degree per LSB); 0 on success. */
int bno055_read_euler(const i2c_bus *b, uint8_t addr, float hrp[3]);
#endif
