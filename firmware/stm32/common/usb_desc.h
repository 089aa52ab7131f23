#ifndef PSMAT_USB_DESC_H
#define PSMAT_USB_DESC_H
/* Descriptors of the psmat CDC-ACM device (USB 2.0 ch. 9, CDC 1.2 / PSTN 1.2), portable:
 * built into the firmware and checked byte by byte by tests/test_usb.c on the host.
 *
 * VID/PID 0x1209/0x0001 is the pid.codes *test* PID: for bench use only, never for devices
 * that leave the lab (a real product needs its own PID, e.g. from pid.codes). */
#include <stddef.h>
#include <stdint.h>

#define USB_VID 0x1209u
#define USB_PID 0x0001u /* pid.codes "Test PID": testing only */
#define USB_BCD_DEVICE 0x0100u

#define USB_EP0_SIZE 64u
#define USB_NOTIF_EP 0x81u /* EP1 IN, interrupt: CDC notifications (never sent, NAKed) */
#define USB_NOTIF_SIZE 8u
#define USB_NOTIF_INTERVAL 16u /* ms */
#define USB_DATA_OUT_EP 0x02u /* EP2 OUT, bulk: host -> device */
#define USB_DATA_IN_EP 0x82u  /* EP2 IN, bulk: device -> host */
#define USB_DATA_SIZE 64u
#define USB_CONFIG_VALUE 1u
#define USB_MAX_POWER_MA 100u
#define USB_COMM_IF 0u
#define USB_DATA_IF 1u

/* string descriptor indices */
#define USB_STR_LANGID 0u
#define USB_STR_MANUFACTURER 1u
#define USB_STR_PRODUCT 2u
#define USB_STR_SERIAL 3u
#define USB_STR_COUNT 4u
#define USB_STR_MAX_CHARS 31u /* longer strings are cut */

/* descriptor types (USB 2.0 table 9-5, CDC 1.2 table 12) */
#define USB_DT_DEVICE 1u
#define USB_DT_CONFIGURATION 2u
#define USB_DT_STRING 3u
#define USB_DT_INTERFACE 4u
#define USB_DT_ENDPOINT 5u
#define USB_DT_CS_INTERFACE 0x24u

#define USB_DEVICE_DESC_LEN 18u
#define USB_CONFIG_DESC_LEN 67u /* 9 + 9 + 5 + 5 + 4 + 5 + 7 + 9 + 7 + 7 */

extern const uint8_t usb_device_desc[USB_DEVICE_DESC_LEN];
extern const uint8_t usb_config_desc[USB_CONFIG_DESC_LEN];

/* Writes string descriptor `index` (LANGID list, or an ASCII string as UTF-16LE) into
 * out[2 + 2 * USB_STR_MAX_CHARS]; returns its length, or 0 for an unknown index.
 * product and serial are NUL-terminated ASCII. */
size_t usb_string_desc(uint8_t index, const char *product, const char *serial,
                       uint8_t out[2 + 2 * USB_STR_MAX_CHARS]);
#endif
