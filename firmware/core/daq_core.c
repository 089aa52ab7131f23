#include "daq_core.h"

#include "text.h"

void daq_init(daq_core *c, const daq_hal *hal)
{
    c->hal = *hal;
    c->running = 0;
}

void daq_on_tick(daq_core *c)
{
    pm_text t;
    if (!c->running)
        return;
    pm_text_init(&t, c->line, DAQ_LINE_MAX);
    for (uint8_t s = 0; s < DAQ_SENSORS; s++) {
        c->hal.select(c->hal.ctx, s);
        pm_text_u32(&t, c->hal.read_adc(c->hal.ctx) & 0x03FFu);
        pm_text_char(&t, s + 1u < DAQ_SENSORS ? ',' : '\r');
    }
    pm_text_char(&t, '\n');
    c->hal.write(c->hal.ctx, (const uint8_t *)c->line, t.len);
}

void daq_on_rx(daq_core *c, const uint8_t *data, size_t n)
{
    for (size_t k = 0; k < n; k++) {
        if (data[k] == 's')
            c->running = 1;
        else if (data[k] == 'f')
            c->running = 0;
    }
}
