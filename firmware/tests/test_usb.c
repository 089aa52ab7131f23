/* The register-free half of the BluePill USB CDC-ACM device: descriptor bytes against the
 * USB 2.0 (ch. 9) and CDC 1.2 / PSTN 1.2 layouts, the EP0 request dispatcher, and the
 * control/bulk IN packetisers (stm32/common/usb_desc.c, usb_ctrl.c). */
#include "check.h"
#include "usb_ctrl.h"
#include "usb_desc.h"

static unsigned le16(const uint8_t *p) { return (unsigned)(p[0] | p[1] << 8); }

static void setup(usb_ctrl *c, usb_reply *r, uint8_t type, uint8_t req, uint16_t value,
                  uint16_t index, uint16_t length)
{
    uint8_t raw[8] = {type, req, (uint8_t)value, (uint8_t)(value >> 8),
                      (uint8_t)index, (uint8_t)(index >> 8),
                      (uint8_t)length, (uint8_t)(length >> 8)};
    usb_setup s;
    usb_setup_parse(&s, raw);
    usb_ctrl_setup(c, &s, r);
}

/* setup(), then the kind of reply; a macro so that a failure names the caller's line */
#define SETUP_KIND(c, r, type, req, value, index, length, want)                            \
    do {                                                                                   \
        setup(c, r, type, req, value, index, length);                                      \
        CHECK_EQ((r)->kind, want);                                                         \
    } while (0)

static void test_device_descriptor(void)
{
    const uint8_t *d = usb_device_desc;
    CHECK_EQ(sizeof usb_device_desc, 18);
    CHECK_EQ(d[0], 18);           /* bLength */
    CHECK_EQ(d[1], 1);            /* DEVICE */
    CHECK_EQ(le16(d + 2), 0x0200); /* bcdUSB */
    CHECK_EQ(d[4], 0x02);         /* bDeviceClass CDC */
    CHECK_EQ(d[5], 0);
    CHECK_EQ(d[6], 0);
    CHECK_EQ(d[7], 64);           /* bMaxPacketSize0 */
    CHECK_EQ(le16(d + 8), 0x1209); /* pid.codes */
    CHECK_EQ(le16(d + 10), 0x0001); /* its test PID */
    CHECK_EQ(le16(d + 12), 0x0100);
    CHECK_EQ(d[14], 1);
    CHECK_EQ(d[15], 2);
    CHECK_EQ(d[16], 3);
    CHECK_EQ(d[17], 1);           /* bNumConfigurations */
}

/* Walks the configuration: every descriptor's bLength adds up to wTotalLength, in the order
 * CDC 1.2 §5.3 asks (interface, its functional descriptors, its endpoints). */
static void test_config_descriptor(void)
{
    const uint8_t *d = usb_config_desc;
    const uint8_t want_types[] = {2, 4, 0x24, 0x24, 0x24, 0x24, 5, 4, 5, 5};
    const uint8_t want_len[] = {9, 9, 5, 5, 4, 5, 7, 9, 7, 7};
    size_t off = 0, sum = 0, n = 0;

    CHECK_EQ(sizeof usb_config_desc, USB_CONFIG_DESC_LEN);
    CHECK_EQ(le16(d + 2), sizeof usb_config_desc); /* wTotalLength */
    while (off < sizeof usb_config_desc && n < sizeof want_types) {
        CHECK_EQ(d[off], want_len[n]);
        CHECK_EQ(d[off + 1], want_types[n]);
        sum += d[off];
        off += d[off];
        n++;
    }
    CHECK_EQ(n, 10);
    CHECK_EQ(off, sizeof usb_config_desc);
    CHECK_EQ(sum, le16(d + 2));

    /* configuration */
    CHECK_EQ(d[4], 2);    /* bNumInterfaces */
    CHECK_EQ(d[5], 1);    /* bConfigurationValue */
    CHECK_EQ(d[6], 0);
    CHECK(d[7] & 0x80);   /* bmAttributes: bit 7 must be set */
    CHECK_EQ(d[7] & 0x1F, 0);
    CHECK_EQ(d[8], 50);   /* 100 mA */

    /* interface 0: CDC communications, ACM */
    d = usb_config_desc + 9;
    CHECK_EQ(d[2], 0);    /* bInterfaceNumber */
    CHECK_EQ(d[3], 0);    /* bAlternateSetting */
    CHECK_EQ(d[4], 1);    /* one endpoint */
    CHECK_EQ(d[5], 0x02); /* Communications Interface Class */
    CHECK_EQ(d[6], 0x02); /* Abstract Control Model */
    CHECK_EQ(d[7], 0x00); /* no class-specific protocol (no AT commands) */

    /* header functional descriptor */
    d = usb_config_desc + 18;
    CHECK_EQ(d[2], 0x00);
    CHECK_EQ(le16(d + 3), 0x0120); /* bcdCDC 1.20 */
    /* call management */
    d = usb_config_desc + 23;
    CHECK_EQ(d[2], 0x01);
    CHECK_EQ(d[3], 0x00); /* device does no call management */
    CHECK_EQ(d[4], 1);    /* bDataInterface */
    /* abstract control management */
    d = usb_config_desc + 28;
    CHECK_EQ(d[2], 0x02);
    CHECK_EQ(d[3], 0x02); /* line coding + control line state + serial state */
    /* union */
    d = usb_config_desc + 32;
    CHECK_EQ(d[2], 0x06);
    CHECK_EQ(d[3], 0);    /* bControlInterface */
    CHECK_EQ(d[4], 1);    /* bSubordinateInterface0 */
    /* notification endpoint */
    d = usb_config_desc + 37;
    CHECK_EQ(d[2], 0x81); /* EP1 IN */
    CHECK_EQ(d[3], 0x03); /* interrupt */
    CHECK_EQ(le16(d + 4), 8);
    CHECK(d[6] >= 1);     /* bInterval 1..255 ms at full speed */

    /* interface 1: CDC data */
    d = usb_config_desc + 44;
    CHECK_EQ(d[2], 1);
    CHECK_EQ(d[3], 0);
    CHECK_EQ(d[4], 2);
    CHECK_EQ(d[5], 0x0A); /* Data Interface Class */
    CHECK_EQ(d[6], 0);
    CHECK_EQ(d[7], 0);
    d = usb_config_desc + 53;
    CHECK_EQ(d[2], 0x02); /* EP2 OUT */
    CHECK_EQ(d[3], 0x02); /* bulk */
    CHECK_EQ(le16(d + 4), 64);
    CHECK_EQ(d[6], 0);
    d = usb_config_desc + 60;
    CHECK_EQ(d[2], 0x82); /* EP2 IN */
    CHECK_EQ(d[3], 0x02);
    CHECK_EQ(le16(d + 4), 64);
    CHECK_EQ(d[6], 0);
}

static void test_strings(void)
{
    uint8_t s[2 + 2 * USB_STR_MAX_CHARS];
    const uint8_t langid[] = {4, 3, 0x09, 0x04};
    const uint8_t serial[] = {18, 3, '0', 0, '1', 0, 'A', 0, 'B', 0, 'C', 0, 'D', 0,
                              'E', 0, 'F', 0};
    char longname[60];
    CHECK_EQ(usb_string_desc(0, "p", "01ABCDEF", s), 4);
    CHECK_BYTES(s, langid, 4);
    CHECK_EQ(usb_string_desc(3, "p", "01ABCDEF", s), 18);
    CHECK_BYTES(s, serial, 18);
    CHECK_EQ(usb_string_desc(1, "p", "x", s), 12); /* "psmat" */
    CHECK_EQ(s[2], 'p');
    CHECK_EQ(s[10], 't');
    CHECK_EQ(usb_string_desc(2, "psmat PSM", "x", s), 20);
    CHECK_EQ(usb_string_desc(4, "p", "x", s), 0);
    CHECK_EQ(usb_string_desc(0xEE, "p", "x", s), 0); /* Microsoft OS string: unknown */
    memset(longname, 'n', sizeof longname - 1);
    longname[sizeof longname - 1] = 0;
    CHECK_EQ(usb_string_desc(2, longname, "x", s), 2 + 2 * USB_STR_MAX_CHARS); /* cut */
    CHECK_EQ(s[0], 2 + 2 * USB_STR_MAX_CHARS);
}

static void test_get_descriptor(void)
{
    usb_ctrl c;
    usb_reply r;
    usb_ctrl_init(&c, "psmat PSM", "01ABCDEF");

    /* Linux asks for 64 bytes of the device descriptor first: 18 come */
    SETUP_KIND(&c, &r, 0x80, 6, 0x0100, 0, 64, USB_REPLY_IN);
    CHECK_EQ(r.len, 18);
    CHECK(r.data == usb_device_desc);
    /* Windows asks for 8 first: truncated to 8 */
    SETUP_KIND(&c, &r, 0x80, 6, 0x0100, 0, 8, USB_REPLY_IN);
    CHECK_EQ(r.len, 8);
    /* configuration header only (9), then all of it (wLength 0xFF > 67) */
    SETUP_KIND(&c, &r, 0x80, 6, 0x0200, 0, 9, USB_REPLY_IN);
    CHECK_EQ(r.len, 9);
    CHECK(r.data == usb_config_desc);
    setup(&c, &r, 0x80, 6, 0x0200, 0, 0xFF);
    CHECK_EQ(r.len, 67);
    /* strings, LANGID and serial, truncated too */
    SETUP_KIND(&c, &r, 0x80, 6, 0x0300, 0, 0xFF, USB_REPLY_IN);
    CHECK_EQ(r.len, 4);
    setup(&c, &r, 0x80, 6, 0x0303, 0x0409, 0xFF);
    CHECK_EQ(r.len, 18);
    CHECK_EQ(r.data[2], '0');
    setup(&c, &r, 0x80, 6, 0x0303, 0x0409, 2);
    CHECK_EQ(r.len, 2);
    CHECK_EQ(r.data[0], 18); /* bLength still says the whole length */
    /* unknown string, DEVICE_QUALIFIER (full-speed only), other configuration index,
     * unknown descriptor type: STALL */
    SETUP_KIND(&c, &r, 0x80, 6, 0x0307, 0x0409, 0xFF, USB_REPLY_STALL);
    SETUP_KIND(&c, &r, 0x80, 6, 0x0600, 0, 10, USB_REPLY_STALL);
    SETUP_KIND(&c, &r, 0x80, 6, 0x0201, 0, 0xFF, USB_REPLY_STALL);
    SETUP_KIND(&c, &r, 0x80, 6, 0x2100, 0, 0xFF, USB_REPLY_STALL);
    /* wrong direction bit */
    SETUP_KIND(&c, &r, 0x00, 6, 0x0100, 0, 18, USB_REPLY_STALL);
    /* wLength 0: no data stage, just the status */
    SETUP_KIND(&c, &r, 0x80, 6, 0x0100, 0, 0, USB_REPLY_ACK);
}

static void test_address_and_configuration(void)
{
    usb_ctrl c;
    usb_reply r;
    usb_ctrl_init(&c, "p", "s");

    /* SET_ADDRESS: acknowledged, applied only after its status stage */
    CHECK_EQ(usb_ctrl_status_in_done(&c), -1);
    SETUP_KIND(&c, &r, 0x00, 5, 23, 0, 0, USB_REPLY_ACK);
    CHECK_EQ(c.address, 0); /* still 0 during the status stage */
    CHECK_EQ(usb_ctrl_status_in_done(&c), 23);
    CHECK_EQ(c.address, 23);
    CHECK_EQ(usb_ctrl_status_in_done(&c), -1); /* once */
    SETUP_KIND(&c, &r, 0x00, 5, 128, 0, 0, USB_REPLY_STALL); /* > 127 */
    CHECK_EQ(usb_ctrl_status_in_done(&c), -1);

    /* GET_CONFIGURATION / SET_CONFIGURATION */
    SETUP_KIND(&c, &r, 0x80, 8, 0, 0, 1, USB_REPLY_IN);
    CHECK_EQ(r.len, 1);
    CHECK_EQ(r.data[0], 0);
    SETUP_KIND(&c, &r, 0x00, 9, 2, 0, 0, USB_REPLY_STALL); /* no configuration 2 */
    SETUP_KIND(&c, &r, 0x00, 9, 1, 0, 0, USB_REPLY_ACK);
    CHECK_EQ(r.event, USB_EV_CONFIGURED);
    setup(&c, &r, 0x80, 8, 0, 0, 1);
    CHECK_EQ(r.data[0], 1);
    /* no SET_ADDRESS pending: the status stage of SET_CONFIGURATION changes nothing */
    CHECK_EQ(usb_ctrl_status_in_done(&c), -1);
    CHECK_EQ(c.address, 23);

    /* GET_STATUS device / interface / endpoint */
    SETUP_KIND(&c, &r, 0x80, 0, 0, 0, 2, USB_REPLY_IN);
    CHECK_EQ(r.len, 2);
    CHECK_EQ(r.data[0], 0); /* bus powered, no remote wakeup */
    CHECK_EQ(r.data[1], 0);
    SETUP_KIND(&c, &r, 0x81, 0, 0, 1, 2, USB_REPLY_IN);
    SETUP_KIND(&c, &r, 0x81, 0, 0, 2, 2, USB_REPLY_STALL); /* no interface 2 */
    SETUP_KIND(&c, &r, 0x82, 0, 0, 0x82, 2, USB_REPLY_IN);
    CHECK_EQ(r.data[0], 0);
    SETUP_KIND(&c, &r, 0x82, 0, 0, 0x83, 2, USB_REPLY_STALL); /* no such endpoint */
    /* halt the bulk IN endpoint, read it back, clear it */
    SETUP_KIND(&c, &r, 0x02, 3, 0, 0x82, 0, USB_REPLY_ACK);
    CHECK_EQ(r.event, USB_EV_SET_HALT);
    CHECK_EQ(r.ep, 0x82);
    setup(&c, &r, 0x82, 0, 0, 0x82, 2);
    CHECK_EQ(r.data[0], 1);
    SETUP_KIND(&c, &r, 0x02, 1, 0, 0x82, 0, USB_REPLY_ACK);
    CHECK_EQ(r.event, USB_EV_CLEAR_HALT);
    setup(&c, &r, 0x82, 0, 0, 0x82, 2);
    CHECK_EQ(r.data[0], 0);
    SETUP_KIND(&c, &r, 0x00, 3, 1, 0, 0, USB_REPLY_STALL); /* DEVICE_REMOTE_WAKEUP: not offered */

    /* GET_INTERFACE / SET_INTERFACE: alternate setting 0 only */
    SETUP_KIND(&c, &r, 0x81, 10, 0, 1, 1, USB_REPLY_IN);
    CHECK_EQ(r.data[0], 0);
    SETUP_KIND(&c, &r, 0x01, 11, 0, 1, 0, USB_REPLY_ACK);
    SETUP_KIND(&c, &r, 0x01, 11, 1, 1, 0, USB_REPLY_STALL);

    /* deconfigure, then a USB reset forgets the address */
    setup(&c, &r, 0x00, 9, 0, 0, 0);
    CHECK_EQ(r.event, USB_EV_UNCONFIGURED);
    /* interfaces exist only when configured */
    SETUP_KIND(&c, &r, 0x81, 10, 0, 1, 1, USB_REPLY_STALL);
    usb_ctrl_bus_reset(&c);
    CHECK_EQ(c.address, 0);
    CHECK_EQ(c.configuration, 0);
}

static void test_cdc_requests(void)
{
    usb_ctrl c;
    usb_reply r;
    usb_setup s;
    const uint8_t coding_1m[7] = {0x40, 0x42, 0x0F, 0x00, 0, 0, 8};
    const uint8_t coding_115k[7] = {0x00, 0xC2, 0x01, 0x00, 0, 0, 8};
    const uint8_t raw_set_coding[8] = {0x21, 0x20, 0, 0, 0, 0, 7, 0};
    usb_ctrl_init(&c, "p", "s");
    setup(&c, &r, 0x00, 9, 1, 0, 0);

    /* GET_LINE_CODING: the default, then truncated */
    SETUP_KIND(&c, &r, 0xA1, 0x21, 0, 0, 7, USB_REPLY_IN);
    CHECK_EQ(r.len, 7);
    CHECK_BYTES(r.data, coding_1m, 7);
    setup(&c, &r, 0xA1, 0x21, 0, 0, 4);
    CHECK_EQ(r.len, 4);
    /* SET_LINE_CODING: an OUT data stage of 7 bytes, committed when complete */
    usb_setup_parse(&s, raw_set_coding);
    usb_ctrl_setup(&c, &s, &r);
    CHECK_EQ(r.kind, USB_REPLY_OUT);
    CHECK_EQ(r.len, 7);
    CHECK(r.out_buf != 0);
    memcpy(r.out_buf, coding_115k, 7);
    CHECK_EQ(usb_ctrl_out_done(&c, &s, 7), 1);
    setup(&c, &r, 0xA1, 0x21, 0, 0, 7);
    CHECK_BYTES(r.data, coding_115k, 7);
    usb_ctrl_setup(&c, &s, &r); /* a short data stage is refused, coding kept */
    r.out_buf[0] = 0x55;
    CHECK_EQ(usb_ctrl_out_done(&c, &s, 3), 0);
    CHECK_EQ(c.line_coding[0], 0x00);
    SETUP_KIND(&c, &r, 0x21, 0x20, 0, 0, 6, USB_REPLY_STALL); /* wrong wLength */

    /* SET_CONTROL_LINE_STATE: bit 0 DTR, bit 1 RTS */
    CHECK_EQ(usb_ctrl_dtr(&c), 0);
    SETUP_KIND(&c, &r, 0x21, 0x22, 0x0002, 0, 0, USB_REPLY_ACK); /* RTS only */
    CHECK_EQ(r.event, USB_EV_LINE_STATE);
    CHECK_EQ(usb_ctrl_dtr(&c), 0);
    setup(&c, &r, 0x21, 0x22, 0x0003, 0, 0);
    CHECK_EQ(usb_ctrl_dtr(&c), 1);
    CHECK_EQ(c.line_state, USB_LINE_DTR | USB_LINE_RTS);
    setup(&c, &r, 0x21, 0x22, 0x0001, 0, 0);
    CHECK_EQ(usb_ctrl_dtr(&c), 1);
    setup(&c, &r, 0x21, 0x22, 0x0000, 0, 0); /* port closed */
    CHECK_EQ(usb_ctrl_dtr(&c), 0);
    setup(&c, &r, 0x21, 0x22, 0x0001, 0, 0);
    CHECK_EQ(usb_ctrl_dtr(&c), 1);
    /* DTR ends with the configuration and with a bus reset */
    setup(&c, &r, 0x00, 9, 0, 0, 0);
    CHECK_EQ(usb_ctrl_dtr(&c), 0);
    setup(&c, &r, 0x00, 9, 1, 0, 0);
    setup(&c, &r, 0x21, 0x22, 0x0001, 0, 0);
    usb_ctrl_bus_reset(&c);
    CHECK_EQ(usb_ctrl_dtr(&c), 0);
    setup(&c, &r, 0x00, 9, 1, 0, 0);

    /* SEND_BREAK accepted; class requests to the data interface are not ours */
    SETUP_KIND(&c, &r, 0x21, 0x23, 0xFFFF, 0, 0, USB_REPLY_ACK);
    SETUP_KIND(&c, &r, 0x21, 0x22, 0x0001, 1, 0, USB_REPLY_STALL);

    /* unknown requests: STALL */
    SETUP_KIND(&c, &r, 0x21, 0x00, 0, 0, 0, USB_REPLY_STALL); /* SEND_ENCAPSULATED_COMMAND */
    SETUP_KIND(&c, &r, 0xA1, 0x01, 0, 0, 64, USB_REPLY_STALL); /* GET_ENCAPSULATED_RESPONSE */
    SETUP_KIND(&c, &r, 0xC0, 0x01, 0, 0, 16, USB_REPLY_STALL); /* vendor */
    /* SET_DESCRIPTOR with IN: nonsense */
    SETUP_KIND(&c, &r, 0x80, 0x07, 0x0100, 0, 18, USB_REPLY_STALL);
    SETUP_KIND(&c, &r, 0x00, 0x07, 0x0100, 0, 18, USB_REPLY_STALL); /* SET_DESCRIPTOR */
    SETUP_KIND(&c, &r, 0x80, 0x0C, 0, 0, 2, USB_REPLY_STALL); /* SYNCH_FRAME */
    SETUP_KIND(&c, &r, 0x60, 0x00, 0, 0, 0, USB_REPLY_STALL); /* reserved type */
    CHECK_EQ(r.event, USB_EV_NONE);
}

static void test_packetisers(void)
{
    uint8_t buf[200];
    usb_in_xfer x;
    const uint8_t *p;
    uint16_t n;

    /* 67-byte configuration for wLength 255: 64 + 3, no ZLP (the 3 end it) */
    usb_in_xfer_start(&x, buf, 67, 255, 64);
    CHECK_EQ(usb_in_xfer_next(&x, 64, &p, &n), 1);
    CHECK(p == buf);
    CHECK_EQ(n, 64);
    CHECK_EQ(usb_in_xfer_next(&x, 64, &p, &n), 1);
    CHECK(p == buf + 64);
    CHECK_EQ(n, 3);
    CHECK_EQ(usb_in_xfer_next(&x, 64, &p, &n), 0);
    /* 128 bytes for wLength 255: 64 + 64 + ZLP */
    usb_in_xfer_start(&x, buf, 128, 255, 64);
    CHECK_EQ(usb_in_xfer_next(&x, 64, &p, &n), 1);
    CHECK_EQ(usb_in_xfer_next(&x, 64, &p, &n), 1);
    CHECK_EQ(n, 64);
    CHECK_EQ(usb_in_xfer_next(&x, 64, &p, &n), 1);
    CHECK_EQ(n, 0);
    CHECK_EQ(usb_in_xfer_next(&x, 64, &p, &n), 0);
    /* 64 bytes for wLength 64: exactly what was asked, no ZLP */
    usb_in_xfer_start(&x, buf, 64, 64, 64);
    CHECK_EQ(usb_in_xfer_next(&x, 64, &p, &n), 1);
    CHECK_EQ(usb_in_xfer_next(&x, 64, &p, &n), 0);
    /* 18 bytes: one short packet */
    usb_in_xfer_start(&x, buf, 18, 64, 64);
    CHECK_EQ(usb_in_xfer_next(&x, 64, &p, &n), 1);
    CHECK_EQ(n, 18);
    CHECK_EQ(usb_in_xfer_next(&x, 64, &p, &n), 0);

    /* bulk IN: a 530-byte frame is 8 full packets, a short one, then idle; a 512-byte
     * transfer ends with a ZLP */
    {
        uint32_t avail = 530;
        int last_full = 0, k, len, packets = 0;
        while ((len = usb_bulk_next_len(avail, last_full, 64)) >= 0) {
            avail -= (uint32_t)len;
            last_full = len == 64;
            packets++;
        }
        CHECK_EQ(packets, 9);
        avail = 512;
        last_full = 0;
        for (k = 0; k < 8; k++) {
            len = usb_bulk_next_len(avail, last_full, 64);
            CHECK_EQ(len, 64);
            avail -= 64;
            last_full = 1;
        }
        CHECK_EQ(usb_bulk_next_len(0, last_full, 64), 0); /* the ZLP */
        CHECK_EQ(usb_bulk_next_len(0, 0, 64), -1);        /* after it: idle */
        CHECK_EQ(usb_bulk_next_len(5, 1, 64), 5);          /* more data: no ZLP needed */
    }
}

int main(void)
{
    test_device_descriptor();
    test_config_descriptor();
    test_strings();
    test_get_descriptor();
    test_address_and_configuration();
    test_cdc_requests();
    test_packetisers();
    return check_report("test_usb");
}
