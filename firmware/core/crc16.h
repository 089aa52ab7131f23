/* CRC-16/CCITT-FALSE (docs/protocol.md, docs/spec.md §5): poly 0x1021, init 0xFFFF, no reflection,
 * no final XOR. Check value: pm_crc16("123456789", 9) == 0x29B1. */
#ifndef PSMAT_CRC16_H
#define PSMAT_CRC16_H

#include <stddef.h>
#include <stdint.h>

#define PM_CRC16_INIT 0xFFFFu

/* Incremental form: crc = PM_CRC16_INIT; crc = pm_crc16_update(crc, chunk, n); ... */
uint16_t pm_crc16_update(uint16_t crc, const uint8_t *data, size_t n);
uint16_t pm_crc16(const uint8_t *data, size_t n);

#ifndef PM_CRC16_BITWISE
/* table[b]: the register after the byte b is shifted through the polynomial from zero (crc16.c) */
extern const uint16_t pm_crc16_table[256];
#endif

#endif
