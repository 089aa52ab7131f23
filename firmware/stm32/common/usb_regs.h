/* STM32F103 USB full-speed device peripheral (RM0008 rev 21 §23.5), our own definitions.
 * Registers are 32-bit wide with 16 meaningful bits. The 512-byte packet memory (PMA) is
 * seen by the CPU as 256 16-bit words at a 32-bit stride ("2x16-bit" layout): USB-local
 * byte address a (even) is at CPU address 0x40006000 + 2 * a. */
#ifndef PSMAT_USB_REGS_H
#define PSMAT_USB_REGS_H

#include <stdint.h>

typedef struct {
    volatile uint32_t EPR[8];
    uint32_t reserved[8];
    volatile uint32_t CNTR, ISTR, FNR, DADDR, BTABLE;
} usb_regs;

#define USB ((usb_regs *)0x40005C00u)
#define USB_PMA_ADDR 0x40006000u
#define USB_PMA_SIZE 512u

/* CPU pointer to the 16-bit PMA word at USB-local byte address a (a even) */
#define USB_PMA16(a) ((volatile uint16_t *)(USB_PMA_ADDR + 2u * (uint32_t)(a)))

/* CNTR */
#define USB_CNTR_FRES (1u << 0)
#define USB_CNTR_PDWN (1u << 1)
#define USB_CNTR_RESETM (1u << 10)
#define USB_CNTR_CTRM (1u << 15)

/* ISTR (flags are rc_w0: write 0 to clear, 1 leaves them) */
#define USB_ISTR_EP_ID 0x000Fu
#define USB_ISTR_DIR (1u << 4)
#define USB_ISTR_SOF (1u << 9)
#define USB_ISTR_RESET (1u << 10)
#define USB_ISTR_SUSP (1u << 11)
#define USB_ISTR_WKUP (1u << 12)
#define USB_ISTR_ERR (1u << 13)
#define USB_ISTR_PMAOVR (1u << 14)
#define USB_ISTR_CTR (1u << 15)

/* DADDR */
#define USB_DADDR_EF (1u << 7)

/* EPnR: CTR_* are rc_w0, DTOG_* and STAT_* toggle when written with 1, SETUP is read-only,
 * EP_TYPE, EP_KIND and EA are plain read/write. */
#define USB_EP_EA 0x000Fu
#define USB_EP_STAT_TX 0x0030u
#define USB_EP_DTOG_TX 0x0040u
#define USB_EP_CTR_TX 0x0080u
#define USB_EP_KIND 0x0100u
#define USB_EP_TYPE 0x0600u
#define USB_EP_SETUP 0x0800u
#define USB_EP_STAT_RX 0x3000u
#define USB_EP_DTOG_RX 0x4000u
#define USB_EP_CTR_RX 0x8000u
#define USB_EP_RW (USB_EP_TYPE | USB_EP_KIND | USB_EP_EA)

#define USB_EP_BULK (0u << 9)
#define USB_EP_CONTROL (1u << 9)
#define USB_EP_INTERRUPT (3u << 9)

/* STAT values, shifted into place by USB_STAT_TX()/USB_STAT_RX() */
#define USB_STAT_DISABLED 0u
#define USB_STAT_STALL 1u
#define USB_STAT_NAK 2u
#define USB_STAT_VALID 3u
#define USB_STAT_TX(s) ((uint32_t)(s) << 4)
#define USB_STAT_RX(s) ((uint32_t)(s) << 12)

/* buffer descriptor table entry n at BTABLE + 8n: ADDR_TX, COUNT_TX, ADDR_RX, COUNT_RX */
#define USB_BT_ADDR_TX(bt, n) USB_PMA16((bt) + 8u * (n) + 0u)
#define USB_BT_COUNT_TX(bt, n) USB_PMA16((bt) + 8u * (n) + 2u)
#define USB_BT_ADDR_RX(bt, n) USB_PMA16((bt) + 8u * (n) + 4u)
#define USB_BT_COUNT_RX(bt, n) USB_PMA16((bt) + 8u * (n) + 6u)
#define USB_COUNT_RX_MASK 0x03FFu
/* COUNT_RX allocation of 64 bytes: BL_SIZE = 1 (32-byte blocks), NUM_BLOCK = 1 */
#define USB_COUNT_RX_64 ((1u << 15) | (1u << 10))

#define RCC_APB1_USB (1u << 23)
#define IRQ_USB_LP 20u /* USB_LP_CAN1_RX0 */
#define NVIC_ISPR ((volatile uint32_t *)0xE000E200u)

#endif
