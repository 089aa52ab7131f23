/* Material DAQ on the Arduino Nano Every (thesis §2.4.1, docs/spec.md §5): daq_core behind a HAL
 * of blocking USART writes and polled conversions; the RTC paces the 500 ms lines. */
#include "board.h"
#include "daq_core.h"

static uint8_t selected;

static void select(void *ctx, uint8_t sensor) { (void)ctx; selected = sensor; }
static uint16_t read_adc(void *ctx) { (void)ctx; return adc_read_sensor(selected); }
static void send(void *ctx, const uint8_t *data, size_t n)
{
    (void)ctx;
    while (n--)
        usart_put(*data++);
}

static daq_core core;

int main(void)
{
    static const daq_hal hal = {0, select, read_adc, send};
    uint8_t byte;
    board_init();
    daq_init(&core, &hal);
    for (;;) {
        if (usart_get(&byte))
            daq_on_rx(&core, &byte, 1);
        if (tick_take())
            daq_on_tick(&core);
    }
}
