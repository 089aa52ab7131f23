/* link.h over USART1 at 1 Mbit/s (make LINK=uart). */
#include "link.h"

#include "uart.h"

static uint32_t dropped;

void link_init(const char *product, const char *serial)
{
    (void)product;
    (void)serial;
    uart_init(UART_BAUD);
}

size_t link_write(const uint8_t *data, size_t n)
{
    size_t k = uart_write(data, n);
    if (n && !k)
        dropped++;
    return k;
}

size_t link_read(uint8_t *data, size_t max) { return uart_read(data, max); }
int link_rx_pending(void) { return uart_rx_pending(); }
uint32_t link_dropped(void) { return dropped; }
