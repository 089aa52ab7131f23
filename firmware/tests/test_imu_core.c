/* imu_core: v1/v2 frames from the fake sensors, commands. */
#include "check.h"
#include "crc16.h"
#include "imu_core.h"

/* ---- fake hardware: sensor s reads (s + 0.5, -s, 0.0625 s) degrees ----------------- */
typedef struct fake {
    uint8_t out[4096];
    size_t out_len, n_writes, last_at, last_len;
    uint32_t now_us, rate_hz;
} fake;

static void f_read_euler(void *ctx, uint8_t s, float hrp[3])
{
    (void)ctx;
    hrp[0] = (float)s + 0.5f;
    hrp[1] = -(float)s;
    hrp[2] = 0.0625f * (float)s;
}
static void f_write(void *ctx, const uint8_t *data, size_t n)
{
    fake *f = ctx;
    memcpy(f->out + f->out_len, data, n);
    f->last_at = f->out_len;
    f->last_len = n;
    f->out_len += n;
    f->n_writes++;
}
static uint32_t f_micros(void *ctx) { return ((fake *)ctx)->now_us += 100000u; }
static void f_set_rate(void *ctx, uint32_t hz) { ((fake *)ctx)->rate_hz = hz; }

static fake F;
static imu_core C;
/* ------------------------------------------------------------------------------------ */

static const uint8_t *last(void) { return F.out + F.last_at; }

static int command(uint8_t opcode, uint32_t arg)
{
    uint8_t pkt[PM_CMD_LEN];
    pm_encode_command(opcode, arg, pkt);
    imu_on_rx(&C, pkt, sizeof pkt);
    CHECK_EQ(last()[3], PM_TYPE_REPLY);
    CHECK_EQ(last()[16], opcode);
    return last()[17];
}

int main(void)
{
    imu_hal hal = {&F, f_read_euler, f_write, f_micros, f_set_rate};
    char text[PM_REPLY_TEXT_MAX + 1];
    imu_init(&C, &hal, PM_PROTO_V2, "IMU7");

    imu_on_tick(&C); /* streams from power-up, v2 */
    CHECK_EQ(F.last_len, 78);
    CHECK_BYTES(last(), "\xA5\x5A\x02\x02\x00\x00\x00\x00\xA0\x86\x01\x00\x05\x03\x3C\x00", 16);
    /* sensor 1: heading 1.5 = 0x3FC00000, roll -1.0 = 0xBF800000, pitch 0.0625 = 0x3D800000 */
    CHECK_BYTES(last() + 16 + 12, "\x00\x00\xC0\x3F\x00\x00\x80\xBF\x00\x00\x80\x3D", 12);
    CHECK_EQ(last()[76] | last()[77] << 8, pm_crc16(last() + 2, 74));

    CHECK_EQ(command(PM_OP_SET_PROTOCOL, 1), PM_ST_OK);
    imu_on_tick(&C);
    CHECK_EQ(F.last_len, 64);
    CHECK_BYTES(last(), "\xFF\xFF\x00\x00\x00\x3F", 6); /* INIT INIT, heading 0.5 */

    CHECK_EQ(command(PM_OP_SET_RATE, 101), PM_ST_BAD_ARG);
    CHECK_EQ(command(PM_OP_SET_RATE, 50), PM_ST_OK);
    CHECK_EQ(F.rate_hz, 50);
    CHECK_EQ(command(PM_OP_CAL_HOLD, 0), PM_ST_UNKNOWN);
    CHECK_EQ(command(PM_OP_IDENTIFY, 0), PM_ST_OK);
    memcpy(text, last() + 18, F.last_len - 20);
    text[F.last_len - 20] = '\0';
    CHECK(strcmp(text, "device=imu fw=0.1.0 sensors=5 rate=50 proto=1 serial=IMU7 units=deg") == 0);

    CHECK_EQ(command(PM_OP_STOP, 0), PM_ST_OK);
    F.n_writes = 0;
    imu_on_tick(&C);
    CHECK_EQ(F.n_writes, 0);
    CHECK_EQ(command(PM_OP_START, 0), PM_ST_OK);
    CHECK_EQ(command(PM_OP_SET_PROTOCOL, 2), PM_ST_OK);
    imu_on_tick(&C);
    CHECK_EQ(last()[4], 2); /* seq counts frames sent: 0 (v2), 1 (v1), now 2 */
    return check_report("test_imu_core");
}
