/* Standard requests (USB 2.0 §9.4) and CDC PSTN class requests (PSTN 1.2 §6.3) for one
 * configuration with a communications and a data interface. */
#include "usb_ctrl.h"

/* bmRequestType fields */
#define RT_DIR_IN 0x80u
#define RT_TYPE_MASK 0x60u
#define RT_STANDARD 0x00u
#define RT_CLASS 0x20u
#define RT_RECIP_MASK 0x1Fu
#define RT_DEVICE 0u
#define RT_INTERFACE 1u
#define RT_ENDPOINT 2u

/* bRequest: standard (table 9-4) and CDC PSTN (table 13) */
#define GET_STATUS 0x00u
#define CLEAR_FEATURE 0x01u
#define SET_FEATURE 0x03u
#define SET_ADDRESS 0x05u
#define GET_DESCRIPTOR 0x06u
#define GET_CONFIGURATION 0x08u
#define SET_CONFIGURATION 0x09u
#define GET_INTERFACE 0x0Au
#define SET_INTERFACE 0x0Bu
#define SET_LINE_CODING 0x20u
#define GET_LINE_CODING 0x21u
#define SET_CONTROL_LINE_STATE 0x22u
#define SEND_BREAK 0x23u

#define FEATURE_ENDPOINT_HALT 0u

void usb_setup_parse(usb_setup *s, const uint8_t raw[8])
{
    s->bmRequestType = raw[0];
    s->bRequest = raw[1];
    s->wValue = (uint16_t)(raw[2] | raw[3] << 8);
    s->wIndex = (uint16_t)(raw[4] | raw[5] << 8);
    s->wLength = (uint16_t)(raw[6] | raw[7] << 8);
}

void usb_ctrl_init(usb_ctrl *c, const char *product, const char *serial)
{
    static const uint8_t coding[7] = {0x40, 0x42, 0x0F, 0x00, 0, 0, 8}; /* 1000000 8N1 */
    c->product = product;
    c->serial = serial;
    for (unsigned k = 0; k < sizeof coding; k++)
        c->line_coding[k] = coding[k];
    usb_ctrl_bus_reset(c);
}

void usb_ctrl_bus_reset(usb_ctrl *c)
{
    c->address = c->pending_address = c->address_pending = 0;
    c->configuration = 0;
    c->line_state = 0;
    c->halted = 0;
}

/* bit of `halted` for a data endpoint address, 0 for EP0 and unknown endpoints */
static uint8_t halt_bit(uint8_t ep)
{
    switch (ep) {
    case USB_DATA_OUT_EP: return 1u;
    case USB_DATA_IN_EP: return 2u;
    case USB_NOTIF_EP: return 4u;
    default: return 0;
    }
}

static void reply_in(usb_reply *r, const usb_setup *s, const uint8_t *data, size_t len)
{
    r->kind = USB_REPLY_IN;
    r->data = data;
    r->len = (uint16_t)(len < s->wLength ? len : s->wLength); /* never more than asked */
}

static void get_descriptor(usb_ctrl *c, const usb_setup *s, usb_reply *r)
{
    uint8_t type = (uint8_t)(s->wValue >> 8), index = (uint8_t)s->wValue;
    size_t n;
    switch (type) {
    case USB_DT_DEVICE:
        if (index == 0)
            reply_in(r, s, usb_device_desc, sizeof usb_device_desc);
        break;
    case USB_DT_CONFIGURATION:
        if (index == 0)
            reply_in(r, s, usb_config_desc, sizeof usb_config_desc);
        break;
    case USB_DT_STRING:
        n = usb_string_desc(index, c->product, c->serial, c->scratch);
        if (n)
            reply_in(r, s, c->scratch, n);
        break;
    default: /* DEVICE_QUALIFIER, OTHER_SPEED...: a full-speed-only device STALLs */
        break;
    }
}

static void standard_request(usb_ctrl *c, const usb_setup *s, usb_reply *r)
{
    uint8_t recip = s->bmRequestType & RT_RECIP_MASK, in = s->bmRequestType & RT_DIR_IN;
    uint8_t ep = (uint8_t)s->wIndex, bit;

    switch (s->bRequest) {
    case GET_STATUS:
        if (!in || s->wValue != 0)
            return;
        c->scratch[0] = c->scratch[1] = 0; /* bus powered, no remote wakeup, not halted */
        if (recip == RT_ENDPOINT) {
            bit = halt_bit(ep);
            if ((ep & 0x7Fu) != 0 && (!bit || !c->configuration))
                return;
            c->scratch[0] = (c->halted & bit) ? 1u : 0u;
        } else if (recip == RT_INTERFACE) {
            if (!c->configuration || s->wIndex > USB_DATA_IF)
                return;
        } else if (recip != RT_DEVICE) {
            return;
        }
        reply_in(r, s, c->scratch, 2);
        return;
    case CLEAR_FEATURE:
    case SET_FEATURE:
        /* only ENDPOINT_HALT on our data/notification endpoints (no remote wakeup, and
         * TEST_MODE is for high-speed devices) */
        if (in || recip != RT_ENDPOINT || s->wValue != FEATURE_ENDPOINT_HALT ||
            !c->configuration || !(bit = halt_bit(ep)))
            return;
        if (s->bRequest == SET_FEATURE) {
            c->halted |= bit;
            r->event = USB_EV_SET_HALT;
        } else {
            c->halted &= (uint8_t)~bit;
            r->event = USB_EV_CLEAR_HALT;
        }
        r->ep = ep;
        r->kind = USB_REPLY_ACK;
        return;
    case SET_ADDRESS:
        if (in || recip != RT_DEVICE || s->wValue > 127 || s->wIndex || s->wLength)
            return;
        c->pending_address = (uint8_t)s->wValue; /* programmed after the status stage */
        c->address_pending = 1;
        r->kind = USB_REPLY_ACK;
        return;
    case GET_DESCRIPTOR:
        if (in && recip == RT_DEVICE)
            get_descriptor(c, s, r);
        return;
    case GET_CONFIGURATION:
        if (in && recip == RT_DEVICE)
            reply_in(r, s, &c->configuration, 1);
        return;
    case SET_CONFIGURATION:
        if (in || recip != RT_DEVICE || s->wValue > USB_CONFIG_VALUE)
            return;
        c->configuration = (uint8_t)s->wValue;
        c->halted = 0;
        if (!c->configuration)
            c->line_state = 0;
        r->event = c->configuration ? USB_EV_CONFIGURED : USB_EV_UNCONFIGURED;
        r->kind = USB_REPLY_ACK;
        return;
    case GET_INTERFACE:
        if (in && recip == RT_INTERFACE && c->configuration && s->wIndex <= USB_DATA_IF) {
            c->scratch[0] = 0; /* one alternate setting each */
            reply_in(r, s, c->scratch, 1);
        }
        return;
    case SET_INTERFACE:
        if (!in && recip == RT_INTERFACE && c->configuration && s->wIndex <= USB_DATA_IF &&
            s->wValue == 0)
            r->kind = USB_REPLY_ACK;
        return;
    default:
        return;
    }
}

static void class_request(usb_ctrl *c, const usb_setup *s, usb_reply *r)
{
    uint8_t in = s->bmRequestType & RT_DIR_IN;
    if ((s->bmRequestType & RT_RECIP_MASK) != RT_INTERFACE || s->wIndex != USB_COMM_IF)
        return;
    switch (s->bRequest) {
    case SET_LINE_CODING:
        if (!in && s->wLength == sizeof c->line_coding) {
            r->kind = USB_REPLY_OUT;
            r->out_buf = c->scratch;
            r->len = s->wLength;
        }
        return;
    case GET_LINE_CODING:
        if (in)
            reply_in(r, s, c->line_coding, sizeof c->line_coding);
        return;
    case SET_CONTROL_LINE_STATE:
        if (!in && s->wLength == 0) {
            c->line_state = (uint8_t)(s->wValue & (USB_LINE_DTR | USB_LINE_RTS));
            r->event = USB_EV_LINE_STATE;
            r->kind = USB_REPLY_ACK;
        }
        return;
    case SEND_BREAK: /* accepted and ignored: the link has no break condition */
        if (!in && s->wLength == 0)
            r->kind = USB_REPLY_ACK;
        return;
    default:
        return;
    }
}

void usb_ctrl_setup(usb_ctrl *c, const usb_setup *s, usb_reply *r)
{
    r->kind = USB_REPLY_STALL;
    r->event = USB_EV_NONE;
    r->ep = 0;
    r->data = 0;
    r->out_buf = 0;
    r->len = 0;
    switch (s->bmRequestType & RT_TYPE_MASK) {
    case RT_STANDARD: standard_request(c, s, r); break;
    case RT_CLASS: class_request(c, s, r); break;
    default: break; /* vendor, reserved */
    }
    /* a device-to-host request with wLength 0 has no data stage (USB 2.0 §9.3.5) */
    if (r->kind == USB_REPLY_IN && s->wLength == 0)
        r->kind = USB_REPLY_ACK;
}

int usb_ctrl_out_done(usb_ctrl *c, const usb_setup *s, uint16_t len)
{
    if ((s->bmRequestType & RT_TYPE_MASK) == RT_CLASS && s->bRequest == SET_LINE_CODING &&
        len == sizeof c->line_coding) {
        for (unsigned k = 0; k < sizeof c->line_coding; k++)
            c->line_coding[k] = c->scratch[k];
        return 1;
    }
    return 0;
}

int usb_ctrl_status_in_done(usb_ctrl *c)
{
    if (!c->address_pending)
        return -1;
    c->address_pending = 0;
    c->address = c->pending_address;
    return c->address;
}

void usb_in_xfer_start(usb_in_xfer *x, const uint8_t *data, uint16_t len, uint16_t wLength,
                       uint16_t maxpkt)
{
    x->p = data;
    x->left = len;
    x->zlp = (uint8_t)(len < wLength && len % maxpkt == 0);
}

int usb_in_xfer_next(usb_in_xfer *x, uint16_t maxpkt, const uint8_t **p, uint16_t *n)
{
    if (x->left) {
        *n = x->left < maxpkt ? x->left : maxpkt;
        *p = x->p;
        x->p += *n;
        x->left = (uint16_t)(x->left - *n);
        return 1;
    }
    if (x->zlp) {
        x->zlp = 0;
        *p = x->p;
        *n = 0;
        return 1;
    }
    return 0;
}

int usb_bulk_next_len(uint32_t avail, int last_full, uint16_t maxpkt)
{
    if (avail)
        return (int)(avail < maxpkt ? avail : maxpkt);
    return last_full ? 0 : -1;
}
