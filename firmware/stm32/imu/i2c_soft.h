#ifndef PSMAT_IMU_I2C_SOFT_H
#define PSMAT_IMU_I2C_SOFT_H
#include <stdint.h>

#include "regs.h"

/* Bit-banged I2C master, ~100 kHz, open-drain pins on one port, honours clock stretching
 * (the BNO055 stretches SCL). The F103 has two I2C peripherals and the spine needs three
 * buses (docs/spec.md §5), so all three are done the same way in software. */
typedef struct i2c_bus {
    gpio_regs *port;
    uint8_t scl, sda; /* pin numbers */
} i2c_bus;

void i2c_init(const i2c_bus *b);
/* 0 on success, -1 on a missing ACK or a stuck clock */
int i2c_write_reg(const i2c_bus *b, uint8_t addr, uint8_t reg, uint8_t value);
int i2c_read_regs(const i2c_bus *b, uint8_t addr, uint8_t reg, uint8_t *out, uint8_t n);
#endif
