/* imu_hal for the BluePill: five BNO055 on three buses, 2 + 2 + 1 (docs/spec.md §5). */
#include "hal.h"

#include "bno055.h"
#include "micros.h"
#include "tick.h"
#include "link.h"

static const i2c_bus buses[3] = {
    {GPIOB, 6, 7},   /* bus 0: PB6 SCL, PB7 SDA (I2C1 pins) */
    {GPIOB, 10, 11}, /* bus 1: PB10 SCL, PB11 SDA (I2C2 pins) */
    {GPIOB, 8, 9},   /* bus 2: PB8 SCL, PB9 SDA (I2C1 remap pins) */
};

static const struct { uint8_t bus, addr; } sensors[IMU_SENSORS] = {
    {0, BNO055_ADDR_A}, {0, BNO055_ADDR_B}, {1, BNO055_ADDR_A}, {1, BNO055_ADDR_B},
    {2, BNO055_ADDR_A},
};

static uint8_t ready[IMU_SENSORS];

void hal_sensors_init(void)
{
    RCC->APB2ENR |= RCC_APB2_IOPB;
    for (int k = 0; k < 3; k++)
        i2c_init(&buses[k]);
    delay_us(1000u * BNO055_BOOT_MS);
    for (uint8_t s = 0; s < IMU_SENSORS; s++)
        ready[s] = bno055_init(&buses[sensors[s].bus], sensors[s].addr) == 0;
}

/* A sensor that is absent or fails a read gives NaN: the host sees the gap. */
static void read_euler(void *ctx, uint8_t s, float hrp[3])
{
    union { uint32_t u; float f; } nan = {0x7FC00000u};
    (void)ctx;
    if (!ready[s] || bno055_read_euler(&buses[sensors[s].bus], sensors[s].addr, hrp))
        hrp[0] = hrp[1] = hrp[2] = nan.f;
}

static void send(void *ctx, const uint8_t *d, size_t n) { (void)ctx; link_write(d, n); }
static uint32_t now_us(void *ctx) { (void)ctx; return micros(); }
static void set_rate(void *ctx, uint32_t hz) { (void)ctx; tick_set_rate(hz); }

const imu_hal bluepill_imu_hal = {0, read_euler, send, now_us, set_rate};
