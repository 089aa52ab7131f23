#ifndef PSMAT_PSM_MUX_H
#define PSMAT_PSM_MUX_H
#include <stdint.h>
/* Mux address lines (Code 2.3), LSB first: rows PB12-PB15, columns PA15, PB3, PB4, PB5. */
void mux_init(void);
void mux_set_row(uint8_t addr);
void mux_set_col(uint8_t addr);
#endif
