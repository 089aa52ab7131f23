/* Minimal BNO055 driver (Bosch BST-BNO055-DS000, §3.3, §4.3): page 0 registers only. */
#include "bno055.h"

#include "micros.h"

#define REG_CHIP_ID 0x00u
#define REG_PAGE_ID 0x07u
#define REG_EUL_HEADING_LSB 0x1Au /* heading, roll, pitch: 3 x int16 LE */
#define REG_UNIT_SEL 0x3Bu
#define REG_OPR_MODE 0x3Du
#define REG_PWR_MODE 0x3Eu
#define CHIP_ID 0xA0u
#define MODE_CONFIG 0x00u
#define MODE_NDOF 0x0Cu

int bno055_init(const i2c_bus *b, uint8_t addr)
{
    uint8_t id;
    if (i2c_read_regs(b, addr, REG_CHIP_ID, &id, 1) || id != CHIP_ID)
        return -1;
    if (i2c_write_reg(b, addr, REG_OPR_MODE, MODE_CONFIG))
        return -1;
    delay_us(25000); /* any mode -> CONFIG: 19 ms */
    if (i2c_write_reg(b, addr, REG_PAGE_ID, 0) || i2c_write_reg(b, addr, REG_PWR_MODE, 0) ||
        i2c_write_reg(b, addr, REG_UNIT_SEL, 0) /* degrees */ ||
        i2c_write_reg(b, addr, REG_OPR_MODE, MODE_NDOF))
        return -1;
    delay_us(10000); /* CONFIG -> any mode: 7 ms */
    return 0;
}

int bno055_read_euler(const i2c_bus *b, uint8_t addr, float hrp[3])
{
    uint8_t raw[6];
    if (i2c_read_regs(b, addr, REG_EUL_HEADING_LSB, raw, sizeof raw))
        return -1;
    for (int k = 0; k < 3; k++)
        hrp[k] = (float)(int16_t)(raw[2 * k] | raw[2 * k + 1] << 8) / 16.0f;
    return 0;
}
