/* Register side of the CDC-ACM device (RM0008 §23): PMA/BTABLE, endpoint registers, EP0
 * stages and the bulk pipes. The decisions (descriptors, requests, packet lengths) are in
 * the portable usb_ctrl.c / usb_desc.c / ring.c, tested on the host.
 *
 * Writers (TIM2 scan IRQ, main loop) only touch the TX ring and pend the USB interrupt;
 * all endpoint registers and PMA accesses happen in the USB interrupt. */
#include "usb_cdc.h"

#include "micros.h"
#include "regs.h"
#include "ring.h"
#include "usb_ctrl.h"
#include "usb_regs.h"

/* PMA layout, USB-local byte addresses (512 bytes in all) */
#define PMA_BTABLE 0x000u  /* 3 entries x 8 bytes */
#define EP0_RX 0x040u  /* 64 */
#define EP0_TX 0x080u  /* 64 */
#define EP1_TX 0x0C0u  /* notification IN, 8 (reserved 16) */
#define EP2_RX 0x0D0u  /* bulk OUT, 64 */
#define EP2_TX 0x110u  /* bulk IN, 64; ends at 0x150 */

#define EP_NOTIF 1u
#define EP_DATA 2u

#define D_PLUS_PIN 12u
#define REENUMERATE_US 10000u

typedef enum { EP0_IDLE, EP0_DATA_IN, EP0_DATA_OUT, EP0_STATUS_IN, EP0_STATUS_OUT } ep0_stage;

static usb_ctrl ctrl;
static usb_setup setup;
static usb_in_xfer ep0_in;
static ep0_stage stage;
static uint8_t *out_buf;
static uint16_t out_len, out_got;

static uint8_t tx_mem[USB_CDC_TX_RING];
static pm_ring tx;
static volatile uint8_t dtr;
static uint8_t in_busy, last_full;
static volatile uint32_t dropped;
static usb_cdc_rx_fn rx_cb;

/* ---- endpoint register writes (rc_w0 CTR bits written 1 = kept, toggles written 0) ---- */

static void ep_set_tx(unsigned n, unsigned stat)
{
    uint32_t v = USB->EPR[n];
    USB->EPR[n] = (v & USB_EP_RW) | USB_EP_CTR_RX | USB_EP_CTR_TX |
                  ((v & USB_EP_STAT_TX) ^ USB_STAT_TX(stat));
}

static void ep_set_rx(unsigned n, unsigned stat)
{
    uint32_t v = USB->EPR[n];
    USB->EPR[n] = (v & USB_EP_RW) | USB_EP_CTR_RX | USB_EP_CTR_TX |
                  ((v & USB_EP_STAT_RX) ^ USB_STAT_RX(stat));
}

static void ep_set_both(unsigned n, unsigned tx_stat, unsigned rx_stat)
{
    uint32_t v = USB->EPR[n];
    USB->EPR[n] = (v & USB_EP_RW) | USB_EP_CTR_RX | USB_EP_CTR_TX |
                  ((v & (USB_EP_STAT_TX | USB_EP_STAT_RX)) ^
                   (USB_STAT_TX(tx_stat) | USB_STAT_RX(rx_stat)));
}

static void ep_clear_ctr_rx(unsigned n)
{
    USB->EPR[n] = (USB->EPR[n] & USB_EP_RW) | USB_EP_CTR_TX;
}

static void ep_clear_ctr_tx(unsigned n)
{
    USB->EPR[n] = (USB->EPR[n] & USB_EP_RW) | USB_EP_CTR_RX;
}

/* Type and address, the given STAT values, both data toggles back to DATA0, CTR cleared. */
static void ep_open(unsigned n, uint32_t type, unsigned tx_stat, unsigned rx_stat)
{
    uint32_t v = USB->EPR[n];
    uint32_t toggles = USB_EP_STAT_TX | USB_EP_STAT_RX | USB_EP_DTOG_TX | USB_EP_DTOG_RX;
    USB->EPR[n] = type | n | ((v & toggles) ^ (USB_STAT_TX(tx_stat) | USB_STAT_RX(rx_stat)));
}

/* Data toggle of one direction back to DATA0 (CLEAR_FEATURE(ENDPOINT_HALT)). */
static void ep_reset_toggle(unsigned n, uint32_t dtog_bit)
{
    uint32_t v = USB->EPR[n];
    USB->EPR[n] = (v & USB_EP_RW) | USB_EP_CTR_RX | USB_EP_CTR_TX | (v & dtog_bit);
}

/* ---- packet memory: 16-bit words at a 32-bit stride ---------------------------------- */

static void pma_write(uint16_t addr, const uint8_t *d, uint16_t n)
{
    volatile uint16_t *p = USB_PMA16(addr);
    for (uint16_t k = 0; k < n; k += 2, p += 2)
        *p = (uint16_t)(d[k] | (k + 1u < n ? d[k + 1] << 8 : 0));
}

static void pma_read(uint16_t addr, uint8_t *d, uint16_t n)
{
    volatile const uint16_t *p = USB_PMA16(addr);
    for (uint16_t k = 0; k < n; k += 2, p += 2) {
        uint16_t w = *p;
        d[k] = (uint8_t)w;
        if (k + 1u < n)
            d[k + 1] = (uint8_t)(w >> 8);
    }
}

static uint16_t rx_count(unsigned n)
{
    return (uint16_t)(*USB_BT_COUNT_RX(PMA_BTABLE, n) & USB_COUNT_RX_MASK);
}

/* ---- bulk IN pipe -------------------------------------------------------------------- */

static void link_down(void)
{
    dtr = 0;
    ring_flush(&tx);
    in_busy = 0;
    last_full = 0;
}

static void tx_kick(void)
{
    uint8_t pkt[USB_DATA_SIZE];
    int n;
    if (!dtr || in_busy || (ctrl.halted & 2u))
        return;
    n = usb_bulk_next_len(ring_used(&tx), last_full, USB_DATA_SIZE);
    if (n < 0)
        return;
    ring_read(&tx, pkt, (size_t)n);
    pma_write(EP2_TX, pkt, (uint16_t)n);
    *USB_BT_COUNT_TX(PMA_BTABLE, EP_DATA) = (uint16_t)n;
    ep_set_tx(EP_DATA, USB_STAT_VALID);
    in_busy = 1;
    last_full = n == (int)USB_DATA_SIZE;
}

size_t usb_cdc_write(const uint8_t *data, size_t n)
{
    if (!n)
        return 0;
    if (!dtr || !ring_write_all(&tx, data, n)) {
        dropped = dropped + 1u;
        return 0;
    }
    NVIC_ISPR[IRQ_USB_LP / 32u] = 1u << (IRQ_USB_LP % 32u); /* the IRQ starts the IN */
    return n;
}

int usb_cdc_dtr(void) { return dtr; }

uint32_t usb_cdc_dropped(void) { return dropped; }

/* ---- EP0 ----------------------------------------------------------------------------- */

static void ep0_send_next(void)
{
    const uint8_t *p;
    uint16_t n;
    if (usb_in_xfer_next(&ep0_in, USB_EP0_SIZE, &p, &n)) {
        pma_write(EP0_TX, p, n);
        *USB_BT_COUNT_TX(PMA_BTABLE, 0) = n;
        ep_set_tx(0, USB_STAT_VALID);
    } else {
        stage = EP0_STATUS_OUT; /* all data sent: wait for the host's zero-length OUT */
    }
}

static void ep0_status_in(void)
{
    *USB_BT_COUNT_TX(PMA_BTABLE, 0) = 0;
    ep_set_both(0, USB_STAT_VALID, USB_STAT_NAK);
    stage = EP0_STATUS_IN;
}

static void apply_event(const usb_reply *r)
{
    uint8_t now;
    switch (r->event) {
    case USB_EV_CONFIGURED:
        ep_open(EP_NOTIF, USB_EP_INTERRUPT, USB_STAT_NAK, USB_STAT_DISABLED);
        ep_open(EP_DATA, USB_EP_BULK, USB_STAT_NAK, USB_STAT_VALID);
        link_down(); /* DTR comes with SET_CONTROL_LINE_STATE */
        break;
    case USB_EV_UNCONFIGURED:
        ep_open(EP_NOTIF, USB_EP_INTERRUPT, USB_STAT_DISABLED, USB_STAT_DISABLED);
        ep_open(EP_DATA, USB_EP_BULK, USB_STAT_DISABLED, USB_STAT_DISABLED);
        link_down();
        break;
    case USB_EV_LINE_STATE:
        now = (uint8_t)usb_ctrl_dtr(&ctrl);
        if (now != dtr) { /* port opened or closed: start clean, no stale frames */
            dtr = 0;
            ring_flush(&tx);
            if (in_busy)
                ep_set_tx(EP_DATA, USB_STAT_NAK);
            in_busy = 0;
            last_full = 0;
            dtr = now;
        }
        break;
    case USB_EV_SET_HALT:
        if (r->ep == USB_DATA_OUT_EP)
            ep_set_rx(EP_DATA, USB_STAT_STALL);
        else
            ep_set_tx(r->ep == USB_DATA_IN_EP ? EP_DATA : EP_NOTIF, USB_STAT_STALL);
        break;
    case USB_EV_CLEAR_HALT:
        if (r->ep == USB_DATA_OUT_EP) {
            ep_reset_toggle(EP_DATA, USB_EP_DTOG_RX);
            ep_set_rx(EP_DATA, USB_STAT_VALID);
        } else if (r->ep == USB_DATA_IN_EP) {
            ep_reset_toggle(EP_DATA, USB_EP_DTOG_TX);
            ep_set_tx(EP_DATA, USB_STAT_NAK);
            in_busy = 0;
            last_full = 0;
        } else {
            ep_reset_toggle(EP_NOTIF, USB_EP_DTOG_TX);
            ep_set_tx(EP_NOTIF, USB_STAT_NAK);
        }
        break;
    case USB_EV_NONE:
        break;
    }
}

static void ep0_setup(void)
{
    uint8_t raw[8];
    usb_reply r;
    uint16_t n = rx_count(0);
    pma_read(EP0_RX, raw, 8);
    ep_clear_ctr_rx(0);
    if (n != 8) {
        ep_set_both(0, USB_STAT_STALL, USB_STAT_STALL);
        stage = EP0_IDLE;
        return;
    }
    usb_setup_parse(&setup, raw);
    usb_ctrl_setup(&ctrl, &setup, &r);
    apply_event(&r);
    switch (r.kind) {
    case USB_REPLY_STALL:
        ep_set_both(0, USB_STAT_STALL, USB_STAT_STALL);
        stage = EP0_IDLE;
        break;
    case USB_REPLY_ACK:
        ep0_status_in();
        break;
    case USB_REPLY_IN:
        usb_in_xfer_start(&ep0_in, r.data, r.len, setup.wLength, USB_EP0_SIZE);
        stage = EP0_DATA_IN;
        ep_set_rx(0, USB_STAT_VALID); /* the status OUT may come once the host has enough */
        ep0_send_next();
        break;
    case USB_REPLY_OUT:
        out_buf = r.out_buf;
        out_len = r.len;
        out_got = 0;
        stage = EP0_DATA_OUT;
        ep_set_both(0, USB_STAT_NAK, USB_STAT_VALID);
        break;
    }
}

static void ep0_out(void)
{
    uint16_t n = rx_count(0), take;
    if (stage == EP0_DATA_OUT) {
        take = (uint16_t)(n < out_len - out_got ? n : out_len - out_got);
        pma_read(EP0_RX, out_buf + out_got, take);
        out_got = (uint16_t)(out_got + take);
        ep_clear_ctr_rx(0);
        if (out_got < out_len && n == USB_EP0_SIZE) {
            ep_set_rx(0, USB_STAT_VALID);
        } else if (usb_ctrl_out_done(&ctrl, &setup, out_got)) {
            ep0_status_in();
        } else {
            ep_set_both(0, USB_STAT_STALL, USB_STAT_STALL);
            stage = EP0_IDLE;
        }
        return;
    }
    /* the status OUT of an IN request (or a stray OUT): the transfer is over */
    ep_clear_ctr_rx(0);
    if (stage == EP0_DATA_IN || stage == EP0_STATUS_OUT)
        ep_set_tx(0, USB_STAT_NAK);
    stage = EP0_IDLE;
    ep_set_rx(0, USB_STAT_VALID);
}

static void ep0_in_done(void)
{
    int addr;
    ep_clear_ctr_tx(0);
    if (stage == EP0_DATA_IN) {
        ep0_send_next();
    } else if (stage == EP0_STATUS_IN) {
        addr = usb_ctrl_status_in_done(&ctrl);
        if (addr >= 0) /* SET_ADDRESS takes effect only now (USB 2.0 §9.4.6) */
            USB->DADDR = USB_DADDR_EF | (uint32_t)addr;
        stage = EP0_IDLE;
        ep_set_rx(0, USB_STAT_VALID);
    }
}

/* ---- reset and interrupt ------------------------------------------------------------- */

static void bus_reset(void)
{
    USB->BTABLE = PMA_BTABLE;
    *USB_BT_ADDR_TX(PMA_BTABLE, 0) = EP0_TX;
    *USB_BT_COUNT_TX(PMA_BTABLE, 0) = 0;
    *USB_BT_ADDR_RX(PMA_BTABLE, 0) = EP0_RX;
    *USB_BT_COUNT_RX(PMA_BTABLE, 0) = USB_COUNT_RX_64;
    *USB_BT_ADDR_TX(PMA_BTABLE, EP_NOTIF) = EP1_TX;
    *USB_BT_COUNT_TX(PMA_BTABLE, EP_NOTIF) = 0;
    *USB_BT_ADDR_RX(PMA_BTABLE, EP_NOTIF) = 0;
    *USB_BT_COUNT_RX(PMA_BTABLE, EP_NOTIF) = 0;
    *USB_BT_ADDR_TX(PMA_BTABLE, EP_DATA) = EP2_TX;
    *USB_BT_COUNT_TX(PMA_BTABLE, EP_DATA) = 0;
    *USB_BT_ADDR_RX(PMA_BTABLE, EP_DATA) = EP2_RX;
    *USB_BT_COUNT_RX(PMA_BTABLE, EP_DATA) = USB_COUNT_RX_64;
    ep_open(0, USB_EP_CONTROL, USB_STAT_NAK, USB_STAT_VALID);
    ep_open(EP_NOTIF, USB_EP_INTERRUPT, USB_STAT_DISABLED, USB_STAT_DISABLED);
    ep_open(EP_DATA, USB_EP_BULK, USB_STAT_DISABLED, USB_STAT_DISABLED);
    USB->DADDR = USB_DADDR_EF; /* address 0, function enabled */
    usb_ctrl_bus_reset(&ctrl);
    stage = EP0_IDLE;
    link_down();
}

static void data_out(void)
{
    uint8_t pkt[USB_DATA_SIZE];
    uint16_t n = rx_count(EP_DATA);
    if (n > USB_DATA_SIZE)
        n = USB_DATA_SIZE;
    pma_read(EP2_RX, pkt, n);
    ep_clear_ctr_rx(EP_DATA);
    if (!(ctrl.halted & 1u))
        ep_set_rx(EP_DATA, USB_STAT_VALID);
    if (n && rx_cb)
        rx_cb(pkt, n);
}

void USB_LP_CAN1_RX0_IRQHandler(void);
void USB_LP_CAN1_RX0_IRQHandler(void)
{
    uint32_t istr;
    if (USB->ISTR & USB_ISTR_RESET) {
        USB->ISTR = (uint16_t)~USB_ISTR_RESET;
        bus_reset();
    }
    while ((istr = USB->ISTR) & USB_ISTR_CTR) {
        unsigned n = istr & USB_ISTR_EP_ID;
        uint32_t epr = USB->EPR[n];
        if (n == 0) {
            if (epr & USB_EP_CTR_TX)
                ep0_in_done();
            if (epr & USB_EP_CTR_RX) {
                if (epr & USB_EP_SETUP)
                    ep0_setup();
                else
                    ep0_out();
            }
        } else if (n == EP_DATA) {
            if (epr & USB_EP_CTR_TX) {
                ep_clear_ctr_tx(EP_DATA);
                in_busy = 0;
            }
            if (epr & USB_EP_CTR_RX)
                data_out();
        } else { /* the notification endpoint never sends; nothing else is open */
            USB->EPR[n] = epr & USB_EP_RW;
        }
    }
    tx_kick(); /* also how usb_cdc_write starts a transfer: it pends this interrupt */
}

void usb_cdc_init(const char *product, const char *serial, usb_cdc_rx_fn rx)
{
    ring_init(&tx, tx_mem, sizeof tx_mem);
    rx_cb = rx;
    usb_ctrl_init(&ctrl, product, serial);

    /* D+ low for 10 ms against the board's pull-up: the host sees a detach, so it
     * enumerates us afresh after a reset or a flash (PA12 returns to the USB block below) */
    RCC->APB2ENR |= RCC_APB2_IOPA;
    gpio_config(GPIOA, D_PLUS_PIN, GPIO_OUT_PP_2MHZ);
    GPIOA->BRR = 1u << D_PLUS_PIN;
    delay_us(REENUMERATE_US);
    gpio_config(GPIOA, D_PLUS_PIN, GPIO_IN_FLOAT);

    RCC->APB1ENR |= RCC_APB1_USB;
    USB->CNTR = USB_CNTR_FRES; /* transceiver on (PDWN = 0), still in reset */
    delay_us(2);               /* t_STARTUP = 1 us */
    USB->CNTR = 0;
    USB->ISTR = 0;
    USB->BTABLE = PMA_BTABLE;
    USB->CNTR = USB_CNTR_CTRM | USB_CNTR_RESETM; /* the host's reset then sets us up */
    nvic_enable(IRQ_USB_LP, USB_CDC_IRQ_PRIORITY);
}
