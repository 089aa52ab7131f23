/* link.h over USB CDC-ACM: bulk OUT packets land in an RX ring (USB interrupt -> main). */
#include "link.h"

#include "ring.h"
#include "usb_cdc.h"

#define RX_RING 256u

static uint8_t rx_mem[RX_RING];
static pm_ring rx;
static volatile uint32_t rx_lost;

static void on_rx(const uint8_t *data, size_t n)
{
    if (!ring_write_all(&rx, data, n)) /* the command parser resyncs after a lost chunk */
        rx_lost = rx_lost + 1u;
}

void link_init(const char *product, const char *serial)
{
    ring_init(&rx, rx_mem, sizeof rx_mem);
    usb_cdc_init(product, serial, on_rx);
}

size_t link_write(const uint8_t *data, size_t n) { return usb_cdc_write(data, n); }
size_t link_read(uint8_t *data, size_t max) { return ring_read(&rx, data, max); }
int link_rx_pending(void) { return ring_used(&rx) != 0; }
uint32_t link_dropped(void) { return usb_cdc_dropped(); }
