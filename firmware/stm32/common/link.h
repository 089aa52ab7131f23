#ifndef PSMAT_STM32_LINK_H
#define PSMAT_STM32_LINK_H
/* The host link, chosen at build time (Makefile LINK=usb|uart):
 *   link_usb.c   USB CDC-ACM on PA11/PA12 (default): /dev/ttyACM*, needs DTR
 *   link_uart.c  USART1 at 1 Mbit/s on PA9/PA10 through a USB-serial adapter
 * Both run their interrupt relative to the scan timer at TICK priority 0x80: the USART
 * above it (0x40), the USB below it (0xC0); see README "Pins and links". */
#include <stddef.h>
#include <stdint.h>

/* product names the USB device (iProduct), serial is its iSerial; both must stay valid. */
void link_init(const char *product, const char *serial);
/* Queues all n bytes or none (dropped whole, counted); never blocks. One writer context
 * at a time. */
size_t link_write(const uint8_t *data, size_t n);
size_t link_read(uint8_t *data, size_t max);
int link_rx_pending(void);
uint32_t link_dropped(void);
#endif
