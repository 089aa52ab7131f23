/* ATmega4809 register addresses (data space), written from the datasheet (DS40002173A,
 * "Peripheral Module Address Map") for the peripherals this firmware uses; no avr-libc
 * device header (Debian's avr-libc 2.1 / avr-gcc 5.4 have no ATmega4809 support). */
#ifndef PSMAT_AVR_REGS_H
#define PSMAT_AVR_REGS_H

#include <stdint.h>

#define R8(addr) (*(volatile uint8_t *)(addr))
#define R16(addr) (*(volatile uint16_t *)(addr))

#define CPU_CCP R8(0x0034)
#define CCP_IOREG 0xD8u
#define CLKCTRL_MCLKCTRLB_ADDR 0x0061

/* PORTx: DIRSET +1, PINnCTRL +0x10+n */
#define PORTB 0x0420
#define PORTD 0x0460
#define PORTE 0x0480
#define PORTF 0x04A0
#define PORT_DIRSET(p) R8((p) + 0x01)
#define PORT_PINCTRL(p, n) R8((p) + 0x10 + (n))
#define PORT_ISC_INPUT_DISABLE 0x04u

#define PORTMUX_USARTROUTEA R8(0x05E2)
#define PORTMUX_USART3_ALT1 0x40u /* USART3 on PB4 (TX) / PB5 (RX): the Nano Every's USB bridge */

#define USART3 0x0860
#define USART_RXDATAL R8(USART3 + 0x00)
#define USART_TXDATAL R8(USART3 + 0x02)
#define USART_STATUS R8(USART3 + 0x04)
#define USART_CTRLB R8(USART3 + 0x06)
#define USART_BAUD R16(USART3 + 0x08)
#define USART_RXCIF 0x80u
#define USART_DREIF 0x20u
#define USART_RXEN 0x80u
#define USART_TXEN 0x40u

#define ADC0 0x0600
#define ADC_CTRLA R8(ADC0 + 0x00)
#define ADC_CTRLC R8(ADC0 + 0x02)
#define ADC_MUXPOS R8(ADC0 + 0x06)
#define ADC_COMMAND R8(ADC0 + 0x08)
#define ADC_INTFLAGS R8(ADC0 + 0x0B)
#define ADC_RES R16(ADC0 + 0x10)
#define ADC_ENABLE 0x01u
#define ADC_SAMPCAP 0x40u
#define ADC_REFSEL_VDD 0x10u
#define ADC_PRESC_DIV16 0x03u
#define ADC_STCONV 0x01u
#define ADC_RESRDY 0x01u

#define RTC 0x0140
#define RTC_CLKSEL R8(RTC + 0x07)
#define RTC_PITCTRLA R8(RTC + 0x10)
#define RTC_PITSTATUS R8(RTC + 0x11)
#define RTC_PITINTCTRL R8(RTC + 0x12)
#define RTC_PITINTFLAGS R8(RTC + 0x13)
#define RTC_PIT_CYC16384 (13u << 3) /* 16384 / 32768 Hz = 500 ms */
#define RTC_PITEN 0x01u
#define RTC_PI 0x01u

#define VECTOR_RTC_PIT __vector_4

#endif
