#ifndef PSMAT_AVR_BOARD_H
#define PSMAT_AVR_BOARD_H
#include <stdint.h>

/* Arduino Nano Every: ATmega4809 at 16 MHz (its fuses), USART3 to the USB bridge. */
#define F_CPU_HZ 16000000ul
#define DAQ_BAUD 115200ul

void board_init(void);                 /* clock, USART3, ADC0, 500 ms RTC tick */
void usart_put(uint8_t byte);          /* blocking */
int usart_get(uint8_t *byte);          /* 1 if a byte was waiting */
uint16_t adc_read_sensor(uint8_t sensor); /* sensor 0..9, 10-bit */
uint8_t tick_take(void);               /* 1 once per elapsed 500 ms */
#endif
