#ifndef PSMAT_STM32_UART_H
#define PSMAT_STM32_UART_H
#include <stddef.h>
#include <stdint.h>

/* USART1 on PA9 (TX) / PA10 (RX), interrupt driven through two rings. The USART interrupt
 * priority must be above any code that writes for long (the PSM scan in the TIM2 IRQ). */
#define UART_BAUD 1000000u
#define UART_IRQ_PRIORITY 0x40u
#define UART_TX_RING 2048u /* power of two; holds three 16x16 v2 frames */
#define UART_RX_RING 256u

void uart_init(uint32_t baud);
/* Queues all n bytes, or none if they do not fit (a dropped frame shows as a seq gap).
 * One writer context at a time. */
size_t uart_write(const uint8_t *data, size_t n);
/* Takes up to max received bytes. */
size_t uart_read(uint8_t *data, size_t max);
int uart_rx_pending(void);
#endif
