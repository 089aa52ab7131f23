#ifndef PSMAT_USB_CTRL_H
#define PSMAT_USB_CTRL_H
/* EP0 control-request logic of the CDC-ACM device, with no register access (portable, host
 * tested): the driver hands over each SETUP packet and gets back what to do in the data and
 * status stages. Also the packetisers for control IN data stages and the bulk IN pipe. */
#include <stddef.h>
#include <stdint.h>

#include "usb_desc.h"

typedef struct {
    uint8_t bmRequestType, bRequest;
    uint16_t wValue, wIndex, wLength;
} usb_setup;

/* Decodes the 8 little-endian bytes of a SETUP packet (USB 2.0 table 9-2). */
void usb_setup_parse(usb_setup *s, const uint8_t raw[8]);

typedef enum {
    USB_REPLY_STALL, /* request error: STALL the data/status stage */
    USB_REPLY_ACK,   /* no data stage: the status stage is a zero-length IN packet */
    USB_REPLY_IN,    /* data stage IN (data, len; len already cut to wLength), status OUT */
    USB_REPLY_OUT    /* data stage OUT (len bytes into out_buf), then usb_ctrl_out_done */
} usb_reply_kind;

typedef enum {
    USB_EV_NONE,
    USB_EV_CONFIGURED,   /* SET_CONFIGURATION(1): open the CDC endpoints */
    USB_EV_UNCONFIGURED, /* SET_CONFIGURATION(0): close them */
    USB_EV_LINE_STATE,   /* SET_CONTROL_LINE_STATE: DTR/RTS may have changed */
    USB_EV_SET_HALT,     /* SET_FEATURE(ENDPOINT_HALT) on `ep` */
    USB_EV_CLEAR_HALT    /* CLEAR_FEATURE(ENDPOINT_HALT) on `ep`: also resets its toggle */
} usb_event;

typedef struct {
    usb_reply_kind kind;
    usb_event event;
    uint8_t ep;          /* endpoint address for the HALT events */
    const uint8_t *data; /* IN */
    uint8_t *out_buf;    /* OUT */
    uint16_t len;
} usb_reply;

#define USB_LINE_DTR 0x01u
#define USB_LINE_RTS 0x02u

typedef struct {
    const char *product, *serial;
    uint8_t address;         /* applied */
    uint8_t pending_address; /* SET_ADDRESS waits for its status stage (USB 2.0 §9.4.6) */
    uint8_t address_pending;
    uint8_t configuration;
    uint8_t line_state; /* USB_LINE_DTR | USB_LINE_RTS */
    uint8_t halted;     /* bit 0 data OUT, bit 1 data IN, bit 2 notification IN */
    uint8_t line_coding[7]; /* dwDTERate LE, bCharFormat, bParityType, bDataBits */
    uint8_t scratch[2 + 2 * USB_STR_MAX_CHARS]; /* strings, status words, OUT staging */
} usb_ctrl;

void usb_ctrl_init(usb_ctrl *c, const char *product, const char *serial);
/* USB reset: default address, unconfigured, DTR off, halts cleared (line coding kept). */
void usb_ctrl_bus_reset(usb_ctrl *c);
void usb_ctrl_setup(usb_ctrl *c, const usb_setup *s, usb_reply *r);
/* The OUT data stage of `s` brought len bytes into the reply's out_buf: 1 = ACK the
 * status stage, 0 = STALL it. */
int usb_ctrl_out_done(usb_ctrl *c, const usb_setup *s, uint16_t len);
/* The zero-length status IN packet was sent: returns the address to program now (a
 * deferred SET_ADDRESS), or -1. */
int usb_ctrl_status_in_done(usb_ctrl *c);
static inline int usb_ctrl_dtr(const usb_ctrl *c)
{
    return c->configuration && (c->line_state & USB_LINE_DTR);
}

/* Control IN data stage cut into max-size packets, with the zero-length packet that ends a
 * data stage shorter than wLength whose length is a multiple of the packet size. */
typedef struct {
    const uint8_t *p;
    uint16_t left;
    uint8_t zlp;
} usb_in_xfer;
void usb_in_xfer_start(usb_in_xfer *x, const uint8_t *data, uint16_t len, uint16_t wLength,
                       uint16_t maxpkt);
/* 1 and the next packet (*p, *n; n may be 0) if one is due, 0 when the stage is over. */
int usb_in_xfer_next(usb_in_xfer *x, uint16_t maxpkt, const uint8_t **p, uint16_t *n);

/* Bulk IN: the length of the next packet when `avail` bytes wait and the previous packet
 * was full (last_full) or not; 0 means a zero-length packet (a transfer that ended on a full
 * packet), -1 means send nothing. */
int usb_bulk_next_len(uint32_t avail, int last_full, uint16_t maxpkt);
#endif
