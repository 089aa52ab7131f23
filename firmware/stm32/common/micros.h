#ifndef PSMAT_STM32_MICROS_H
#define PSMAT_STM32_MICROS_H
#include <stdint.h>
void micros_init(void);
uint32_t micros(void); /* free-running 32-bit microsecond clock, wraps every 71.6 min */
void delay_us(uint32_t us); /* waits at least us microseconds (at most us + 1) */
#endif
