/* USART1 at 1 Mbit/s (thesis §2.2.2: "1 Mbit/s (USB)"): BRR = PCLK2 / baud = 48 exactly.
 * Single-producer single-consumer rings: the application fills tx, the IRQ drains it; the
 * IRQ fills rx, the main loop drains it. */
#include "uart.h"

#include "clock.h"
#include "regs.h"

static uint8_t tx_buf[UART_TX_RING], rx_buf[UART_RX_RING];
static volatile uint32_t tx_head, tx_tail, rx_head, rx_tail; /* free-running indices */

void uart_init(uint32_t baud)
{
    RCC->APB2ENR |= RCC_APB2_IOPA | RCC_APB2_USART1;
    gpio_config(GPIOA, 9, GPIO_AF_PP_50MHZ);
    gpio_config(GPIOA, 10, GPIO_IN_PULL);
    GPIOA->BSRR = 1u << 10; /* pull-up */
    USART1->BRR = PCLK2_HZ / baud;
    USART1->CR1 = USART_CR1_UE | USART_CR1_TE | USART_CR1_RE | USART_CR1_RXNEIE;
    nvic_enable(IRQ_USART1, UART_IRQ_PRIORITY);
}

size_t uart_write(const uint8_t *data, size_t n)
{
    uint32_t head = tx_head;
    if (n > UART_TX_RING - (head - tx_tail))
        return 0;
    for (size_t k = 0; k < n; k++)
        tx_buf[(head + k) & (UART_TX_RING - 1u)] = data[k];
    __asm volatile("" ::: "memory"); /* bytes before the index that publishes them */
    tx_head = head + n;
    USART1->CR1 |= USART_CR1_TXEIE;
    return n;
}

size_t uart_read(uint8_t *data, size_t max)
{
    size_t n = 0;
    while (n < max && rx_tail != rx_head) {
        data[n++] = rx_buf[rx_tail & (UART_RX_RING - 1u)];
        rx_tail = rx_tail + 1u;
    }
    return n;
}

int uart_rx_pending(void)
{
    return rx_tail != rx_head;
}

void USART1_IRQHandler(void)
{
    uint32_t sr = USART1->SR;
    if (sr & (USART_SR_RXNE | USART_SR_ORE)) {
        uint8_t b = (uint8_t)USART1->DR; /* also clears ORE */
        if (rx_head - rx_tail < UART_RX_RING) {
            rx_buf[rx_head & (UART_RX_RING - 1u)] = b;
            rx_head = rx_head + 1u;
        }
    }
    if ((USART1->CR1 & USART_CR1_TXEIE) && (sr & USART_SR_TXE)) {
        if (tx_tail != tx_head) {
            USART1->DR = tx_buf[tx_tail & (UART_TX_RING - 1u)];
            tx_tail = tx_tail + 1u;
        } else {
            USART1->CR1 &= ~USART_CR1_TXEIE;
        }
    }
}
