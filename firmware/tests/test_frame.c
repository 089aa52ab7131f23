/* Frame layouts byte by byte, expectations written out by hand from docs/protocol.md. */
#include "check.h"
#include "command.h"
#include "frame.h"

/* A 2x3 frame, row-major: row 0 = 1, 0x234, 0xFFF; row 1 = 0, 0x100, 7. */
static const uint16_t cells_2x3[6] = {0x0001, 0x0234, 0x0FFF, 0x0000, 0x0100, 0x0007};

static void test_psm_v1(void)
{
    /* sum = 1 + 564 + 4095 + 0 + 256 + 7 = 4923; 4923 mod 4096 = 827 = 0x033B */
    static const uint8_t want[16] = {0xFF, 0xFF, 0x01, 0x00, 0x34, 0x02, 0xFF, 0x0F,
                                     0x00, 0x00, 0x00, 0x01, 0x07, 0x00, 0x3B, 0x03};
    uint8_t out[32];
    memset(out, 0xEE, sizeof out);
    CHECK_EQ(psm_encode_v1(cells_2x3, 6, out), 16);
    CHECK_BYTES(out, want, 16);
    CHECK_EQ(out[16], 0xEE); /* nothing written past the frame */
    CHECK_EQ(PSM_V1_LEN(16 * 16), 516);
}

static void test_psm_v2(void)
{
    static const uint8_t want[30] = {
        0xA5, 0x5A, 0x02, 0x01,             /* sync, version 2, type PSM */
        0x04, 0x03, 0x02, 0x01,             /* seq 0x01020304 */
        0xD0, 0xC0, 0xB0, 0xA0,             /* t_us 0xA0B0C0D0 */
        0x02, 0x03, 0x0C, 0x00,             /* rows 2, cols 3, n 12 */
        0x01, 0x00, 0x34, 0x02, 0xFF, 0x0F, /* row 0 */
        0x00, 0x00, 0x00, 0x01, 0x07, 0x00, /* row 1 */
        0x3C, 0x43};                        /* CRC over [2, 28) = 0x433C */
    uint8_t out[40], bytes[12];
    CHECK_EQ(psm_encode_v2(0x01020304u, 0xA0B0C0D0u, 2, 3, cells_2x3, out), 30);
    CHECK_BYTES(out, want, 30);

    /* the generic encoder with the same payload bytes agrees */
    memcpy(bytes, want + 16, 12);
    memset(out, 0, sizeof out);
    CHECK_EQ(pm_encode_v2(PM_TYPE_PSM, 0x01020304u, 0xA0B0C0D0u, 2, 3, bytes, 12, out), 30);
    CHECK_BYTES(out, want, 30);
    CHECK_EQ(PM_V2_LEN(2 * 16 * 16), 530);
}

static void test_imu(void)
{
    /* 1.0f = 0x3F800000 -> 00 00 80 3F; -2.5f = 0xC0200000 -> 00 00 20 C0 */
    float angles[IMU_ANGLES] = {0};
    uint8_t out[80];
    angles[0] = 1.0f;
    angles[14] = -2.5f;

    /* v1: words 0x3F80 + 0xC020 = 0xFFA0; mod 4096 = 0x0FA0 */
    CHECK_EQ(imu_encode_v1(angles, out), 64);
    CHECK_EQ(out[0], 0xFF);
    CHECK_EQ(out[1], 0xFF);
    CHECK_BYTES(out + 2, "\x00\x00\x80\x3F", 4);
    CHECK_BYTES(out + 2 + 56, "\x00\x00\x20\xC0", 4);
    CHECK_EQ(out[6], 0x00); /* angles[1] = 0.0f */
    CHECK_BYTES(out + 62, "\xA0\x0F", 2);

    /* v2: type 2, rows 5, cols 3, n 60, CRC 0x7456 */
    CHECK_EQ(imu_encode_v2(7, 8, angles, out), 78);
    CHECK_BYTES(out, "\xA5\x5A\x02\x02\x07\x00\x00\x00\x08\x00\x00\x00\x05\x03\x3C\x00", 16);
    CHECK_BYTES(out + 16, "\x00\x00\x80\x3F", 4);
    CHECK_BYTES(out + 76, "\x56\x74", 2);
}

static void test_reply(void)
{
    /* IDENTIFY (0x04), OK, text "ab": payload 04 00 61 62, CRC 0x206C */
    static const uint8_t want[22] = {0xA5, 0x5A, 0x02, 0x11, 0x05, 0x00, 0x00, 0x00,
                                     0x06, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00,
                                     0x04, 0x00, 0x61, 0x62, 0x6C, 0x20};
    uint8_t out[PM_REPLY_MAX];
    CHECK_EQ(pm_encode_reply(5, 6, PM_OP_IDENTIFY, PM_ST_OK, "ab", 2, out), 22);
    CHECK_BYTES(out, want, 22);
}

int main(void)
{
    test_psm_v1();
    test_psm_v2();
    test_imu();
    test_reply();
    return check_report("test_frame");
}
