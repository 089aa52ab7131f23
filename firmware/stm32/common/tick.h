#ifndef PSMAT_STM32_TICK_H
#define PSMAT_STM32_TICK_H
#include <stdint.h>
/* TIM2 update interrupt at `hz` (Code 2.4); the application defines tick_irq(). */
void tick_init(uint32_t hz, uint8_t priority);
void tick_set_rate(uint32_t hz);
void tick_irq(void);
#endif
