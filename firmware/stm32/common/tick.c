/* TIM2 paces the scan (Code 2.4). Its clock is 48 MHz; a 1 MHz count covers 16..1000 Hz
 * in 16 bits, a 10 kHz count the slower rates, so 1..1000 Hz all fit. */
#include "tick.h"

#include "clock.h"
#include "regs.h"

void tick_set_rate(uint32_t hz)
{
    uint32_t count_hz = hz >= 16u ? 1000000u : 10000u;
    TIM2->PSC = 2u * PCLK1_HZ / count_hz - 1u;
    TIM2->ARR = count_hz / hz - 1u;
    TIM2->EGR = TIM_EGR_UG; /* load PSC/ARR now; URS keeps this from raising the IRQ */
}

void tick_init(uint32_t hz, uint8_t priority)
{
    RCC->APB1ENR |= RCC_APB1_TIM2;
    TIM2->CR1 = TIM_CR1_URS;
    tick_set_rate(hz);
    TIM2->SR = 0;
    TIM2->DIER = TIM_DIER_UIE;
    nvic_enable(IRQ_TIM2, priority);
    TIM2->CR1 = TIM_CR1_URS | TIM_CR1_CEN;
}

void TIM2_IRQHandler(void)
{
    TIM2->SR = ~TIM_SR_UIF;
    tick_irq();
}
