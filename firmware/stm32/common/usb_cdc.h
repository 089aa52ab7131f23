#ifndef PSMAT_USB_CDC_H
#define PSMAT_USB_CDC_H
/* USB full-speed CDC-ACM device on the STM32F103 USB peripheral (PA11 D-, PA12 D+; the
 * BluePill has the 1.5 kOhm D+ pull-up on the board). Interrupt driven (USB_LP_CAN1_RX0).
 * The host sees /dev/ttyACM*; data flows to it only while it asserts DTR (port open).
 *
 * Priority: USB_CDC_IRQ_PRIORITY is *below* the scan timer (TIM2 at 0x80), deliberately:
 * the USB peripheral NAKs the host by itself while an endpoint waits for service, so a
 * late USB interrupt costs link time, never data; a late or stretched scan would cost
 * sample timing (thesis §2.2.2 saw USB interrupts disturb the timer). See README. */
#include <stddef.h>
#include <stdint.h>

#define USB_CDC_IRQ_PRIORITY 0xC0u
#define USB_CDC_TX_RING 2048u /* power of two: three 530-byte 16x16 v2 frames + replies */

/* Called from the USB interrupt with each bulk OUT packet (1..64 bytes). */
typedef void (*usb_cdc_rx_fn)(const uint8_t *data, size_t n);

/* Needs clock_init() (48 MHz USB clock) and micros_init() (10 ms D+ low to make the host
 * re-enumerate after a reset). product and serial must stay valid. */
void usb_cdc_init(const char *product, const char *serial, usb_cdc_rx_fn rx);
/* Queues all n bytes and returns n, or drops them whole, counts it and returns 0 when DTR
 * is off or the ring lacks room. Never blocks; one writer context at a time. */
size_t usb_cdc_write(const uint8_t *data, size_t n);
int usb_cdc_dtr(void);
uint32_t usb_cdc_dropped(void); /* writes dropped whole so far */
#endif
