/* psm_hal for the BluePill: thin glue from psm_core to the drivers. */
#include "hal.h"

#include "adc.h"
#include "micros.h"
#include "mux.h"
#include "tick.h"
#include "link.h"

static void set_row(void *ctx, uint8_t a) { (void)ctx; mux_set_row(a); }
static void set_col(void *ctx, uint8_t a) { (void)ctx; mux_set_col(a); }
static uint16_t read_adc(void *ctx) { (void)ctx; return adc_read(); }
static void send(void *ctx, const uint8_t *d, size_t n) { (void)ctx; link_write(d, n); }
static uint32_t now_us(void *ctx) { (void)ctx; return micros(); }
static void set_rate(void *ctx, uint32_t hz) { (void)ctx; tick_set_rate(hz); }

const psm_hal bluepill_psm_hal = {0, set_row, set_col, read_adc, send, now_us, set_rate};

