/* Code 2.3, one register write per port: BSRR's low half sets the 1 bits and its high half
 * (the BRR function) clears the 0 bits in the same atomic write. */
#include "mux.h"

#include "regs.h"

void mux_init(void)
{
    RCC->APB2ENR |= RCC_APB2_AFIO | RCC_APB2_IOPA | RCC_APB2_IOPB;
    /* PA15, PB3, PB4 are JTAG pins after reset: keep SWD only (SWJ_CFG = 010) */
    AFIO->MAPR = (AFIO->MAPR & ~(7u << 24)) | (2u << 24);
    for (unsigned pin = 12; pin <= 15; pin++)
        gpio_config(GPIOB, pin, GPIO_OUT_PP_2MHZ);
    gpio_config(GPIOA, 15, GPIO_OUT_PP_2MHZ);
    for (unsigned pin = 3; pin <= 5; pin++)
        gpio_config(GPIOB, pin, GPIO_OUT_PP_2MHZ);
}

void mux_set_row(uint8_t addr)
{
    uint32_t a = addr & 0xFu;
    GPIOB->BSRR = (a << 12) | ((~a & 0xFu) << (12 + 16));
}

void mux_set_col(uint8_t addr)
{
    uint32_t hi = (addr >> 1) & 7u; /* bits 1..3 -> PB3..PB5 */
    GPIOA->BSRR = (addr & 1u) ? 1u << 15 : 1u << (15 + 16);
    GPIOB->BSRR = (hi << 3) | ((~hi & 7u) << (3 + 16));
}
