/* Reset and vector table for the STM32F103 medium-density line (RM0008 table 63): copy
 * .data, clear .bss, call main. Unused vectors go to Default_Handler (a visible hang). */
#include <stdint.h>

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);

void Reset_Handler(void);
void Default_Handler(void);
void TIM2_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));
void USART1_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));
void USB_LP_CAN1_RX0_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));

void Default_Handler(void)
{
    for (;;) {
    }
}

void Reset_Handler(void)
{
    uint32_t *src = &_sidata, *dst = &_sdata;
    while (dst < &_edata)
        *dst++ = *src++;
    for (dst = &_sbss; dst < &_ebss;)
        *dst++ = 0;
    main();
    for (;;) {
    }
}

typedef void (*vector)(void);
#define D Default_Handler

/* 16 core exceptions, then IRQ 0..42; USB_LP_CAN1_RX0 is IRQ 20, TIM2 IRQ 28, USART1
 * IRQ 37. */
__attribute__((section(".isr_vector"), used)) static const vector vectors[16 + 43] = {
    (vector)&_estack, Reset_Handler, D, D, D, D, D, 0, 0, 0, 0, D, D, 0, D, D,
    D, D, D, D, D, D, D, D, D, D,             /* IRQ 0-9 */
    D, D, D, D, D, D, D, D, D, D,             /* IRQ 10-19 */
    USB_LP_CAN1_RX0_IRQHandler, D, D, D, D, D, D, D, TIM2_IRQHandler, D, /* IRQ 20-29 */
    D, D, D, D, D, D, D, USART1_IRQHandler, D, D, /* IRQ 30-39 */
    D, D, D};                                 /* IRQ 40-42 */
