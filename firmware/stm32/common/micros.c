/* A 32-bit 1 MHz counter without interrupts: TIM3 counts microseconds and its update event
 * clocks TIM4 (RM0008 §15.3.15, TIM4 slave on ITR2 = TIM3), so TIM4:TIM3 is the time. */
#include "micros.h"

#include "clock.h"
#include "regs.h"

void micros_init(void)
{
    RCC->APB1ENR |= RCC_APB1_TIM3 | RCC_APB1_TIM4;
    TIM3->PSC = 2u * PCLK1_HZ / 1000000u - 1u;
    TIM3->ARR = 0xFFFFu;
    TIM3->CR2 = 2u << 4; /* MMS = update -> TRGO */
    TIM3->EGR = TIM_EGR_UG;
    TIM4->ARR = 0xFFFFu;
    TIM4->SMCR = (2u << 4) | 7u; /* TS = ITR2, SMS = external clock mode 1 */
    TIM4->CR1 = TIM_CR1_CEN;
    TIM3->CR1 = TIM_CR1_CEN;
}

uint32_t micros(void)
{
    uint32_t hi, lo;
    do { /* re-read if TIM3 wrapped between the two halves */
        hi = TIM4->CNT;
        lo = TIM3->CNT;
    } while (hi != TIM4->CNT);
    return (hi << 16) | (lo & 0xFFFFu);
}

/* At least `us` microseconds: t0 is read somewhere inside a tick of the 1 MHz counter, so
 * waiting for `us` ticks could end after as little as us - 1 µs (delay_us(1): 0-1 µs, and
 * the mux could settle for less than the 1 µs the ADC needs); waiting for us + 1 ticks cannot. */
void delay_us(uint32_t us)
{
    uint32_t t0 = micros();
    while (micros() - t0 <= us) {
    }
}
