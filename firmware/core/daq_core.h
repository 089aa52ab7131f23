/* Material DAQ (thesis §2.4.1, docs/protocol.md "Material DAQ"): 10 sensors, 10-bit ADC,
 * one text line "c0,...,c9\r\n" per 500 ms tick while running; host 's' starts, 'f' stops,
 * any other byte is ignored. Idle from power-up. */
#ifndef PSMAT_DAQ_CORE_H
#define PSMAT_DAQ_CORE_H

#include <stddef.h>
#include <stdint.h>

#define DAQ_SENSORS 10u
#define DAQ_TICK_MS 500u
#define DAQ_LINE_MAX (DAQ_SENSORS * 5u + 1u) /* "1023," x 10, last ',' -> "\r\n" */

typedef struct daq_hal {
    void *ctx;
    void (*select)(void *ctx, uint8_t sensor); /* route sensor 0..9 to the ADC */
    uint16_t (*read_adc)(void *ctx);           /* one 10-bit conversion */
    void (*write)(void *ctx, const uint8_t *data, size_t n);
} daq_hal;

typedef struct daq_core {
    daq_hal hal;
    uint8_t running;
    char line[DAQ_LINE_MAX];
} daq_core;

void daq_init(daq_core *c, const daq_hal *hal);
void daq_on_tick(daq_core *c); /* every DAQ_TICK_MS */
void daq_on_rx(daq_core *c, const uint8_t *data, size_t n);

#endif
