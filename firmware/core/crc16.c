#include "crc16.h"

/* Bitwise, MSB first: no table, so it costs no flash on the MCUs (a 530-byte frame is
 * ~4k shifts, well under the 10 ms frame period). */
uint16_t pm_crc16_update(uint16_t crc, const uint8_t *data, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        crc ^= (uint16_t)((uint16_t)data[i] << 8);
        for (int b = 0; b < 8; b++)
            crc = (crc & 0x8000u) ? (uint16_t)((crc << 1) ^ 0x1021u) : (uint16_t)(crc << 1);
    }
    return crc;
}

uint16_t pm_crc16(const uint8_t *data, size_t n)
{
    return pm_crc16_update(PM_CRC16_INIT, data, n);
}
