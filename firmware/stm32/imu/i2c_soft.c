#include "i2c_soft.h"

#include "micros.h"

#define HALF_US 5u         /* half a bit period: 100 kHz */
#define STRETCH_MAX_US 2000u

static void drive(const i2c_bus *b, uint8_t pin, int high)
{
    b->port->BSRR = high ? 1u << pin : 1u << (pin + 16u); /* high = released (open drain) */
}

static int sda_in(const i2c_bus *b) { return (b->port->IDR >> b->sda) & 1u; }

/* Releases SCL and waits while a slave holds it low. */
static int scl_high(const i2c_bus *b)
{
    uint32_t t0 = micros();
    drive(b, b->scl, 1);
    while (!((b->port->IDR >> b->scl) & 1u))
        if (micros() - t0 > STRETCH_MAX_US)
            return -1;
    delay_us(HALF_US);
    return 0;
}

static int clock_bit(const i2c_bus *b, int bit, int *read)
{
    drive(b, b->sda, bit);
    delay_us(HALF_US);
    if (scl_high(b))
        return -1;
    *read = sda_in(b);
    drive(b, b->scl, 0);
    return 0;
}

static int start(const i2c_bus *b)
{
    drive(b, b->sda, 1);
    if (scl_high(b))
        return -1;
    drive(b, b->sda, 0);
    delay_us(HALF_US);
    drive(b, b->scl, 0);
    return 0;
}

static void stop(const i2c_bus *b)
{
    drive(b, b->sda, 0);
    delay_us(HALF_US);
    scl_high(b);
    drive(b, b->sda, 1);
    delay_us(HALF_US);
}

/* Sends a byte; 0 when the slave ACKs. */
static int put(const i2c_bus *b, uint8_t byte)
{
    int bit;
    for (int k = 7; k >= 0; k--)
        if (clock_bit(b, (byte >> k) & 1, &bit))
            return -1;
    if (clock_bit(b, 1, &bit)) /* release SDA for the ACK */
        return -1;
    return bit ? -1 : 0;
}

/* Receives a byte and ACKs it unless it is the last. */
static int get(const i2c_bus *b, uint8_t *byte, int last)
{
    int bit;
    *byte = 0;
    for (int k = 0; k < 8; k++) {
        if (clock_bit(b, 1, &bit))
            return -1;
        *byte = (uint8_t)(*byte << 1 | bit);
    }
    return clock_bit(b, last, &bit);
}

void i2c_init(const i2c_bus *b)
{
    drive(b, b->scl, 1);
    drive(b, b->sda, 1);
    gpio_config(b->port, b->scl, GPIO_OUT_OD_2MHZ);
    gpio_config(b->port, b->sda, GPIO_OUT_OD_2MHZ);
}

int i2c_write_reg(const i2c_bus *b, uint8_t addr, uint8_t reg, uint8_t value)
{
    int err = start(b) || put(b, (uint8_t)(addr << 1)) || put(b, reg) || put(b, value);
    stop(b);
    return err ? -1 : 0;
}

int i2c_read_regs(const i2c_bus *b, uint8_t addr, uint8_t reg, uint8_t *out, uint8_t n)
{
    int err = start(b) || put(b, (uint8_t)(addr << 1)) || put(b, reg) || start(b) ||
              put(b, (uint8_t)(addr << 1 | 1u));
    for (uint8_t k = 0; !err && k < n; k++)
        err = get(b, &out[k], k + 1u == n);
    stop(b);
    return err ? -1 : 0;
}
