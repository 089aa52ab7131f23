/* psm_core against a fake board: scan order (Code 2.5), framing, every command. */
#include "check.h"
#include "crc16.h"
#include "psm_core.h"

/* ---- fake hardware: everything the core touches, recorded -------------------------- */
#define LOG_MAX 4096
#define OUT_MAX 16384
#define WRITES_MAX 64

typedef struct fake {
    uint8_t row, col;                    /* currently selected mux addresses */
    char log_kind[LOG_MAX];              /* 'r' set_row, 'c' set_col */
    uint8_t log_addr[LOG_MAX];
    size_t n_log, n_reads;
    uint16_t adc_high;                   /* OR-ed into every conversion (test masking) */
    uint8_t out[OUT_MAX];                /* every byte written, concatenated */
    size_t out_len, n_writes, write_at[WRITES_MAX], write_len[WRITES_MAX];
    uint32_t now_us, rate_hz;
    size_t n_set_rate;
} fake;

/* The "sensor": a distinct 12-bit value for each mux address pair. */
static uint16_t pair_value(uint8_t row_addr, uint8_t col_addr)
{
    return (uint16_t)(0x800u | (unsigned)row_addr << 6 | col_addr);
}

static void log_event(fake *f, char kind, uint8_t addr)
{
    if (f->n_log < LOG_MAX) {
        f->log_kind[f->n_log] = kind;
        f->log_addr[f->n_log++] = addr;
    }
}
static void f_set_row(void *ctx, uint8_t a) { fake *f = ctx; f->row = a; log_event(f, 'r', a); }
static void f_set_col(void *ctx, uint8_t a) { fake *f = ctx; f->col = a; log_event(f, 'c', a); }
static uint16_t f_read_adc(void *ctx)
{
    fake *f = ctx;
    f->n_reads++;
    return (uint16_t)(pair_value(f->row, f->col) | f->adc_high);
}
static void f_write(void *ctx, const uint8_t *data, size_t n)
{
    fake *f = ctx;
    f->write_at[f->n_writes] = f->out_len;
    f->write_len[f->n_writes++] = n;
    memcpy(f->out + f->out_len, data, n);
    f->out_len += n;
}
static uint32_t f_micros(void *ctx) { fake *f = ctx; return f->now_us += 1000u; }
static void f_set_rate(void *ctx, uint32_t hz) { fake *f = ctx; f->rate_hz = hz; f->n_set_rate++; }

static fake F;
static psm_core C; /* ~25 KiB: static, as on the MCU */

static void setup(uint8_t rows, uint8_t cols, uint8_t protocol)
{
    psm_hal hal = {&F, f_set_row, f_set_col, f_read_adc, f_write, f_micros, f_set_rate};
    memset(&F, 0, sizeof F);
    psm_init(&C, &hal, rows, cols, protocol, "0000A1B2");
}
/* ------------------------------------------------------------------------------------ */

static const uint8_t *last_write(size_t *len)
{
    *len = F.write_len[F.n_writes - 1];
    return F.out + F.write_at[F.n_writes - 1];
}

static uint16_t u16le(const uint8_t *b) { return (uint16_t)(b[0] | b[1] << 8); }
static uint32_t u32le(const uint8_t *b) { return u16le(b) | (uint32_t)u16le(b + 2) << 16; }

/* Sends one command; checks the reply packet and returns its status (text in `text`). */
static int command(uint8_t opcode, uint32_t arg, char *text)
{
    uint8_t pkt[PM_CMD_LEN];
    size_t writes = F.n_writes, len;
    const uint8_t *r;
    pm_encode_command(opcode, arg, pkt);
    psm_on_rx(&C, pkt, sizeof pkt);
    CHECK_EQ(F.n_writes, writes + 1);
    r = last_write(&len);
    CHECK_BYTES(r, "\xA5\x5A\x02\x11", 4);
    CHECK_EQ(r[12], 0);
    CHECK_EQ(r[13], 0);
    CHECK_EQ(u16le(r + 14), len - 18);
    CHECK_EQ(u16le(r + len - 2), pm_crc16(r + 2, len - 4));
    CHECK_EQ(r[16], opcode);
    if (text) {
        memcpy(text, r + 18, len - 20);
        text[len - 20] = '\0';
    }
    return r[17];
}

static void test_scan_order_and_v2_frame(void)
{
    size_t len, e = 0;
    const uint8_t *fr;
    setup(3, 4, PM_PROTO_V2);
    psm_on_tick(&C);
    CHECK_EQ(F.n_writes, 1);
    /* row i at mux address R-1-i, then columns p = 0..C-1 */
    for (uint8_t i = 0; i < 3; i++) {
        CHECK_EQ(F.log_kind[e], 'r');
        CHECK_EQ(F.log_addr[e++], 2 - i);
        for (uint8_t p = 0; p < 4; p++) {
            CHECK_EQ(F.log_kind[e], 'c');
            CHECK_EQ(F.log_addr[e++], p);
        }
    }
    CHECK_EQ(F.n_log, e);
    CHECK_EQ(F.n_reads, 12);

    fr = last_write(&len);
    CHECK_EQ(len, 16 + 24 + 2);
    CHECK_BYTES(fr, "\xA5\x5A\x02\x01", 4);
    CHECK_EQ(u32le(fr + 4), 0);    /* first frame: seq 0 */
    CHECK_EQ(u32le(fr + 8), 1000); /* micros() at the start of the scan */
    CHECK_EQ(fr[12], 3);
    CHECK_EQ(fr[13], 4);
    CHECK_EQ(u16le(fr + 14), 24);
    for (uint8_t i = 0; i < 3; i++)
        for (uint8_t p = 0; p < 4; p++)
            CHECK_EQ(u16le(fr + 16 + 2 * (i * 4 + p)), pair_value((uint8_t)(2 - i), p));
    CHECK_EQ(u16le(fr + 40), pm_crc16(fr + 2, 38));

    psm_on_tick(&C);
    fr = last_write(&len);
    CHECK_EQ(u32le(fr + 4), 1); /* seq +1 per frame */
}

static void test_v1_and_masking(void)
{
    size_t len;
    const uint8_t *fr;
    setup(16, 16, PM_PROTO_V1);
    F.adc_high = 0xF000; /* out-of-range bits must never reach the wire */
    psm_on_tick(&C);
    fr = last_write(&len);
    CHECK_EQ(len, 516);
    CHECK_EQ(fr[0], 0xFF);
    CHECK_EQ(fr[1], 0xFF);
    for (size_t k = 2; k + 1 < len; k++)
        CHECK(!(fr[k] == 0xFF && fr[k + 1] == 0xFF));
    CHECK_EQ(u16le(fr + 2), pair_value(15, 0)); /* masked to 12 bits */
}

static void test_cal_hold(void)
{
    size_t len;
    const uint8_t *fr;
    setup(3, 4, PM_PROTO_V2);
    CHECK_EQ(command(PM_OP_CAL_HOLD, 1u << 8 | 2u, NULL), PM_ST_OK);
    F.n_log = F.n_reads = 0;
    psm_on_tick(&C);
    /* only the held pair is selected: row 1 -> mux address 3-1-1 = 1, column 2 */
    CHECK_EQ(F.n_log, 2);
    CHECK(F.log_kind[0] == 'r' && F.log_addr[0] == 1);
    CHECK(F.log_kind[1] == 'c' && F.log_addr[1] == 2);
    CHECK_EQ(F.n_reads, 12);
    fr = last_write(&len);
    CHECK_EQ(len, 42);
    for (size_t a = 0; a < 12; a++)
        CHECK_EQ(u16le(fr + 16 + 2 * a), pair_value(1, 2));

    CHECK_EQ(command(PM_OP_CAL_HOLD, 3u << 8, NULL), PM_ST_BAD_ARG);   /* row >= R */
    CHECK_EQ(command(PM_OP_CAL_HOLD, 4u, NULL), PM_ST_BAD_ARG);        /* col >= C */
    CHECK_EQ(command(PM_OP_CAL_HOLD, 0x10000u, NULL), PM_ST_BAD_ARG);
    CHECK_EQ(command(PM_OP_CAL_HOLD, PM_CAL_RESUME, NULL), PM_ST_OK);
    F.n_log = 0;
    psm_on_tick(&C);
    CHECK_EQ(F.n_log, 3 + 12); /* full scan again */
}

static void test_start_stop(void)
{
    size_t writes;
    setup(2, 2, PM_PROTO_V2); /* streams from init */
    psm_on_tick(&C);
    CHECK_EQ(F.n_writes, 1);
    CHECK_EQ(command(PM_OP_STOP, 0, NULL), PM_ST_OK);
    writes = F.n_writes;
    F.n_reads = 0;
    psm_on_tick(&C);
    psm_on_tick(&C);
    CHECK_EQ(F.n_writes, writes); /* silent */
    CHECK_EQ(F.n_reads, 0);
    CHECK_EQ(command(PM_OP_START, 0, NULL), PM_ST_OK);
    psm_on_tick(&C);
    CHECK_EQ(F.n_writes, writes + 2); /* the START reply and one frame */
}

static void test_set_rate(void)
{
    setup(2, 2, PM_PROTO_V2);
    CHECK_EQ(command(PM_OP_SET_RATE, 165, NULL), PM_ST_OK);
    CHECK_EQ(F.n_set_rate, 1);
    CHECK_EQ(F.rate_hz, 165);
    CHECK_EQ(command(PM_OP_SET_RATE, 0, NULL), PM_ST_BAD_ARG);
    CHECK_EQ(command(PM_OP_SET_RATE, 1001, NULL), PM_ST_BAD_ARG);
    CHECK_EQ(F.n_set_rate, 1);
    CHECK_EQ(command(PM_OP_SET_RATE, 1000, NULL), PM_ST_OK);
    CHECK_EQ(F.rate_hz, 1000);
}

static void test_identify_and_protocol(void)
{
    char text[PM_REPLY_TEXT_MAX + 1];
    size_t len;
    setup(16, 16, PM_PROTO_V2);
    CHECK_EQ(command(PM_OP_IDENTIFY, 0, text), PM_ST_OK);
    CHECK(strcmp(text, "device=psm fw=0.1.0 rows=16 cols=16 rate=100 proto=2 "
                       "serial=0000A1B2 r_o=2200 v_ref=3.3 bits=12") == 0);
    CHECK_EQ(command(PM_OP_SET_PROTOCOL, 3, NULL), PM_ST_BAD_ARG);
    CHECK_EQ(command(PM_OP_SET_PROTOCOL, 1, NULL), PM_ST_OK);
    CHECK_EQ(command(PM_OP_SET_RATE, 165, NULL), PM_ST_OK);
    C.v_ref_mv = 5000;
    CHECK_EQ(command(PM_OP_IDENTIFY, 0, text), PM_ST_OK);
    CHECK(strcmp(text, "device=psm fw=0.1.0 rows=16 cols=16 rate=165 proto=1 "
                       "serial=0000A1B2 r_o=2200 v_ref=5.0 bits=12") == 0);
    psm_on_tick(&C);
    last_write(&len);
    CHECK_EQ(len, 516); /* now v1 */
    CHECK_EQ(command(0x7F, 0, NULL), PM_ST_UNKNOWN);
}

static void test_rx_chunks_and_reply_header(void)
{
    uint8_t stream[40] = {0xA5, 0x00, 0xFF};
    size_t n = 3, len;
    const uint8_t *r;
    setup(2, 2, PM_PROTO_V2);
    psm_on_tick(&C);
    psm_on_tick(&C); /* two frames sent */
    n += pm_encode_command(PM_OP_STOP, 0, stream + n);
    n += pm_encode_command(PM_OP_IDENTIFY, 0, stream + n);
    for (size_t k = 0; k < n; k += 5)
        psm_on_rx(&C, stream + k, n - k < 5 ? n - k : 5);
    CHECK_EQ(F.n_writes, 2 + 2);
    r = F.out + F.write_at[2];
    CHECK_EQ(r[16], PM_OP_STOP);
    CHECK_EQ(u32le(r + 4), 2); /* a reply carries the seq of the next frame */
    r = last_write(&len);
    CHECK_EQ(r[16], PM_OP_IDENTIFY);
    CHECK_EQ(C.dev.streaming, 0);
}

static void test_init_limits(void)
{
    setup(0, 200, 9);
    CHECK_EQ(C.rows, 1);
    CHECK_EQ(C.cols, PSM_MAX_COLS);
    CHECK_EQ(C.dev.protocol, PM_PROTO_V2);
    CHECK_EQ(C.dev.streaming, 1);
    CHECK_EQ(C.dev.rate_hz, 100);
}

int main(void)
{
    test_scan_order_and_v2_frame();
    test_v1_and_masking();
    test_cal_hold();
    test_start_stop();
    test_set_rate();
    test_identify_and_protocol();
    test_rx_chunks_and_reply_header();
    test_init_limits();
    return check_report("test_psm_core");
}
