#ifndef PSMAT_STM32_CLOCK_H
#define PSMAT_STM32_CLOCK_H
#define SYSCLK_HZ 48000000u /* 48 MHz: USB needs it (thesis §2.2.2, before Code 2.4) */
#define PCLK1_HZ 24000000u  /* APB1 <= 36 MHz; its timers run at 2 x PCLK1 = 48 MHz */
#define PCLK2_HZ 48000000u
void clock_init(void);
#endif
