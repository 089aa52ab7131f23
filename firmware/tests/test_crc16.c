/* CRC-16/CCITT-FALSE: catalogue check value and vectors (docs/protocol.md). */
#include "check.h"
#include "crc16.h"

int main(void)
{
    const uint8_t digits[] = "123456789";
    const uint8_t zero = 0x00, a = 'A';
    uint16_t crc;

    CHECK_EQ(pm_crc16(digits, 9), 0x29B1);
    CHECK_EQ(pm_crc16(digits, 0), 0xFFFF); /* init, no final XOR */
    CHECK_EQ(pm_crc16(&zero, 1), 0xE1F0);
    CHECK_EQ(pm_crc16(&a, 1), 0xB915);

    /* incremental: any split gives the one-shot value */
    for (size_t cut = 0; cut <= 9; cut++) {
        crc = pm_crc16_update(PM_CRC16_INIT, digits, cut);
        crc = pm_crc16_update(crc, digits + cut, 9 - cut);
        CHECK_EQ(crc, 0x29B1);
    }

#ifndef PM_CRC16_BITWISE
    /* the table is the bitwise recurrence: byte b shifted through the polynomial from zero */
    for (unsigned b = 0; b < 256; b++) {
        uint16_t r = (uint16_t)(b << 8);
        for (int k = 0; k < 8; k++)
            r = (r & 0x8000u) ? (uint16_t)((r << 1) ^ 0x1021u) : (uint16_t)(r << 1);
        CHECK_EQ(pm_crc16_table[b], r);
    }
#endif
    return check_report("test_crc16");
}
