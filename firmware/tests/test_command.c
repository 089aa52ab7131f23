/* Command packets and the incremental parser: byte-by-byte, garbage, chunks, bad CRC. */
#include "check.h"
#include "command.h"

#define MAX_CMDS 8

/* Feeds data in chunks of `chunk` bytes; returns the number of commands found. */
static size_t feed(pm_cmd_parser *p, const uint8_t *data, size_t n, size_t chunk, pm_cmd *cmds)
{
    size_t found = 0;
    for (size_t off = 0; off < n; off += chunk) {
        size_t end = off + chunk < n ? off + chunk : n;
        for (size_t k = off; k < end; k++)
            if (pm_cmd_push(p, data[k], &cmds[found]) && found + 1 < MAX_CMDS)
                found++;
    }
    return found;
}

static void test_encode(void)
{
    /* SET_RATE 165 (0xA5 inside the arg, like a sync byte): CRC over 02 10 03 A5 00 00 00 */
    static const uint8_t want[11] = {0xA5, 0x5A, 0x02, 0x10, 0x03, 0xA5,
                                     0x00, 0x00, 0x00, 0x48, 0x33};
    uint8_t out[PM_CMD_LEN];
    CHECK_EQ(pm_encode_command(PM_OP_SET_RATE, 165, out), 11);
    CHECK_BYTES(out, want, 11);
}

static void test_byte_by_byte(void)
{
    uint8_t pkt[PM_CMD_LEN];
    pm_cmd cmds[MAX_CMDS];
    pm_cmd_parser p;
    pm_cmd_parser_init(&p);
    pm_encode_command(PM_OP_CAL_HOLD, 0x0102, pkt);
    for (size_t k = 0; k + 1 < PM_CMD_LEN; k++)
        CHECK_EQ(pm_cmd_push(&p, pkt[k], &cmds[0]), 0);
    CHECK_EQ(pm_cmd_push(&p, pkt[PM_CMD_LEN - 1], &cmds[0]), 1);
    CHECK_EQ(cmds[0].opcode, PM_OP_CAL_HOLD);
    CHECK_EQ(cmds[0].arg, 0x0102);
    CHECK_EQ(p.len, 0);
}

static void test_garbage_prefix(void)
{
    /* junk, a lone sync byte, a wrong version, then a header cut short (A5 5A 02 10) whose
     * 7 "body" bytes start the real command: only the CRC can reject it. */
    uint8_t stream[64] = {0x00, 0xFF, 0xA5, 0xA5, 0x5A, 0x03, 0xA5, 0x5A, 0x02, 0x10};
    size_t n = 10;
    pm_cmd cmds[MAX_CMDS];
    pm_cmd_parser p;
    n += pm_encode_command(PM_OP_START, 0, stream + n);
    pm_cmd_parser_init(&p);
    CHECK_EQ(feed(&p, stream, n, 1, cmds), 1);
    CHECK_EQ(cmds[0].opcode, PM_OP_START);
    CHECK_EQ(cmds[0].arg, 0);
}

static void test_chunks(void)
{
    uint8_t stream[2 * PM_CMD_LEN + 3] = {0x17};
    size_t n = 1;
    pm_cmd cmds[MAX_CMDS];
    n += pm_encode_command(PM_OP_SET_PROTOCOL, 1, stream + n);
    stream[n++] = 0xA5;
    n += pm_encode_command(PM_OP_SET_RATE, 1000, stream + n);
    stream[n++] = 0x5A;
    for (size_t chunk = 1; chunk <= n; chunk++) {
        pm_cmd_parser p;
        pm_cmd_parser_init(&p);
        CHECK_EQ(feed(&p, stream, n, chunk, cmds), 2);
        CHECK_EQ(cmds[0].opcode, PM_OP_SET_PROTOCOL);
        CHECK_EQ(cmds[0].arg, 1);
        CHECK_EQ(cmds[1].opcode, PM_OP_SET_RATE);
        CHECK_EQ(cmds[1].arg, 1000);
    }
}

static void test_bad_crc(void)
{
    uint8_t pkt[PM_CMD_LEN], good[PM_CMD_LEN];
    pm_cmd cmds[MAX_CMDS];
    pm_encode_command(PM_OP_STOP, 0, good);
    /* every single-bit error after the sync is rejected */
    for (size_t bit = 16; bit < 8 * PM_CMD_LEN; bit++) {
        pm_cmd_parser p;
        pm_cmd_parser_init(&p);
        memcpy(pkt, good, sizeof pkt);
        pkt[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        CHECK_EQ(feed(&p, pkt, sizeof pkt, 1, cmds), 0);
        /* and the parser still takes the next good command */
        CHECK_EQ(feed(&p, good, sizeof good, 1, cmds), 1);
        CHECK_EQ(cmds[0].opcode, PM_OP_STOP);
    }
}

int main(void)
{
    test_encode();
    test_byte_by_byte();
    test_garbage_prefix();
    test_chunks();
    test_bad_crc();
    return check_report("test_command");
}
