#ifndef PSMAT_PSM_ADC_H
#define PSMAT_PSM_ADC_H
#include <stdint.h>
/* ADC1 channel 0 (PA0), 13.5-cycle sampling, one polled conversion per call (Code 2.5). */
void adc_init(void);
uint16_t adc_read(void);
#endif
