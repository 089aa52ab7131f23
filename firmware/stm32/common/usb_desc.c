/* The descriptor bytes, laid out by hand from USB 2.0 §9.6 and CDC 1.2 §5 / PSTN 1.2 §5.3. */
#include "usb_desc.h"

#define LE16(v) (uint8_t)((v) & 0xFFu), (uint8_t)((v) >> 8)

const uint8_t usb_device_desc[USB_DEVICE_DESC_LEN] = {
    USB_DEVICE_DESC_LEN, USB_DT_DEVICE,
    LE16(0x0200u),        /* bcdUSB 2.0 (full speed) */
    0x02, 0x00, 0x00,     /* bDeviceClass CDC; the interfaces say the rest */
    USB_EP0_SIZE,         /* bMaxPacketSize0 */
    LE16(USB_VID), LE16(USB_PID), LE16(USB_BCD_DEVICE),
    USB_STR_MANUFACTURER, USB_STR_PRODUCT, USB_STR_SERIAL,
    1,                    /* bNumConfigurations */
};

const uint8_t usb_config_desc[USB_CONFIG_DESC_LEN] = {
    /* configuration (USB 2.0 table 9-10) */
    9, USB_DT_CONFIGURATION, LE16(USB_CONFIG_DESC_LEN),
    2,                    /* bNumInterfaces */
    USB_CONFIG_VALUE, 0,  /* bConfigurationValue, iConfiguration */
    0x80,                 /* bmAttributes: bus powered, no remote wakeup */
    USB_MAX_POWER_MA / 2, /* bMaxPower in 2 mA units */

    /* interface 0: communications class, abstract control model, no AT protocol */
    9, USB_DT_INTERFACE, USB_COMM_IF, 0, 1, 0x02, 0x02, 0x00, 0,
    /* header functional descriptor (CDC 1.2 table 15): bcdCDC 1.20 */
    5, USB_DT_CS_INTERFACE, 0x00, LE16(0x0120u),
    /* call management (PSTN table 3): no call management, data interface 1 */
    5, USB_DT_CS_INTERFACE, 0x01, 0x00, USB_DATA_IF,
    /* abstract control management (PSTN table 4): bit 1 = line coding, control line
     * state, serial state */
    4, USB_DT_CS_INTERFACE, 0x02, 0x02,
    /* union (CDC 1.2 table 16): control interface 0, subordinate interface 1 */
    5, USB_DT_CS_INTERFACE, 0x06, USB_COMM_IF, USB_DATA_IF,
    /* notification endpoint: interrupt IN */
    7, USB_DT_ENDPOINT, USB_NOTIF_EP, 0x03, LE16(USB_NOTIF_SIZE), USB_NOTIF_INTERVAL,

    /* interface 1: data class, two bulk endpoints */
    9, USB_DT_INTERFACE, USB_DATA_IF, 0, 2, 0x0A, 0x00, 0x00, 0,
    7, USB_DT_ENDPOINT, USB_DATA_OUT_EP, 0x02, LE16(USB_DATA_SIZE), 0,
    7, USB_DT_ENDPOINT, USB_DATA_IN_EP, 0x02, LE16(USB_DATA_SIZE), 0,
};

size_t usb_string_desc(uint8_t index, const char *product, const char *serial,
                       uint8_t out[2 + 2 * USB_STR_MAX_CHARS])
{
    const char *s;
    size_t n = 0;
    switch (index) {
    case USB_STR_LANGID:
        out[0] = 4;
        out[1] = USB_DT_STRING;
        out[2] = 0x09; /* 0x0409 English (United States) */
        out[3] = 0x04;
        return 4;
    case USB_STR_MANUFACTURER: s = "psmat"; break;
    case USB_STR_PRODUCT: s = product; break;
    case USB_STR_SERIAL: s = serial; break;
    default: return 0;
    }
    if (!s)
        s = "";
    for (; s[n] && n < USB_STR_MAX_CHARS; n++) {
        out[2 + 2 * n] = (uint8_t)(s[n] & 0x7F); /* ASCII -> UTF-16LE */
        out[3 + 2 * n] = 0;
    }
    out[0] = (uint8_t)(2 + 2 * n);
    out[1] = USB_DT_STRING;
    return 2 + 2 * n;
}
