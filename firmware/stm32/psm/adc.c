/* Code 2.5 with registers: ADC clock 12 MHz (clock.c), 13.5 + 12.5 cycles = 2.2 us per
 * conversion, software trigger, at least 1 us of mux settling between the select lines' write
 * and the conversion's start (delay_us(1) waits at least 1 us: micros.c). */
#include "adc.h"

#include "micros.h"
#include "regs.h"

void adc_init(void)
{
    RCC->APB2ENR |= RCC_APB2_IOPA | RCC_APB2_ADC1;
    gpio_config(GPIOA, 0, GPIO_ANALOG);
    ADC1->SMPR2 = 2u;  /* SMP0 = 010: 13.5 cycles */
    ADC1->SQR1 = 0;    /* one conversion in the sequence */
    ADC1->SQR3 = 0;    /* ... of channel 0 */
    ADC1->CR2 = ADC_CR2_ADON | ADC_CR2_EXTSEL_SWSTART | ADC_CR2_EXTTRIG;
    delay_us(2); /* t_STAB before calibration */
    ADC1->CR2 |= ADC_CR2_RSTCAL;
    while (ADC1->CR2 & ADC_CR2_RSTCAL) {
    }
    ADC1->CR2 |= ADC_CR2_CAL;
    while (ADC1->CR2 & ADC_CR2_CAL) {
    }
}

uint16_t adc_read(void)
{
    delay_us(1);
    ADC1->CR2 |= ADC_CR2_SWSTART;
    while (!(ADC1->SR & ADC_SR_EOC)) {
    }
    return (uint16_t)ADC1->DR; /* reading DR clears EOC */
}
