#ifndef PSMAT_STM32_UID_H
#define PSMAT_STM32_UID_H
/* 8 hex digits folded from the 96-bit unique device ID: the IDENTIFY serial. */
void uid_serial(char out[9]);
#endif
