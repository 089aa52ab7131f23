/* HSE 8 MHz x 6 = 48 MHz on the PLL (RM0008 §7.2): 1 flash wait state, APB1 /2, APB2 /1,
 * ADC /4 = 12 MHz (Code 2.5, <= 14 MHz), USB = PLL /1 = 48 MHz. */
#include "clock.h"

#include "regs.h"

void clock_init(void)
{
    RCC->CR |= RCC_CR_HSEON;
    while (!(RCC->CR & RCC_CR_HSERDY)) {
    }
    FLASH->ACR = (1u << 4) | 1u; /* prefetch on, latency 1 (24 < SYSCLK <= 48 MHz) */
    RCC->CFGR = (1u << 22)       /* USBPRE: PLL not divided */
                | (4u << 18)     /* PLLMUL x6 */
                | (1u << 16)     /* PLLSRC = HSE */
                | (1u << 14)     /* ADCPRE /4 */
                | (4u << 8);     /* PPRE1 /2 */
    RCC->CR |= RCC_CR_PLLON;
    while (!(RCC->CR & RCC_CR_PLLRDY)) {
    }
    RCC->CFGR |= 2u; /* SW = PLL */
    while (((RCC->CFGR >> 2) & 3u) != 2u) {
    }
}
