#include "command.h"

#include "crc16.h"

void pm_cmd_parser_init(pm_cmd_parser *p)
{
    p->len = 0;
}

/* Could b[0..n) be the start of a command? (sync, version and type are fixed) */
static int is_prefix(const uint8_t *b, uint8_t n)
{
    static const uint8_t head[4] = {PM_SYNC0, PM_SYNC1, PM_VERSION, PM_TYPE_COMMAND};
    for (uint8_t k = 0; k < n && k < 4u; k++)
        if (b[k] != head[k])
            return 0;
    return 1;
}

static int crc_ok(const pm_cmd_parser *p)
{
    uint16_t got = (uint16_t)(p->buf[9] | (p->buf[10] << 8));
    return pm_crc16(p->buf + 2, 7) == got;
}

/* Drops buf[0], then keeps the longest tail of buf that is still a plausible prefix. */
static void resync(pm_cmd_parser *p)
{
    uint8_t s = 1;
    while (s < p->len && !is_prefix(p->buf + s, (uint8_t)(p->len - s)))
        s++;
    for (uint8_t k = s; k < p->len; k++)
        p->buf[k - s] = p->buf[k];
    p->len = (uint8_t)(p->len - s);
}

int pm_cmd_push(pm_cmd_parser *p, uint8_t byte, pm_cmd *cmd)
{
    p->buf[p->len++] = byte;
    if (!is_prefix(p->buf, p->len)) {
        resync(p);
        return 0;
    }
    if (p->len < PM_CMD_LEN)
        return 0;
    if (!crc_ok(p)) {
        resync(p);
        return 0;
    }
    cmd->opcode = p->buf[4];
    cmd->arg = (uint32_t)p->buf[5] | ((uint32_t)p->buf[6] << 8) | ((uint32_t)p->buf[7] << 16) |
               ((uint32_t)p->buf[8] << 24);
    p->len = 0;
    return 1;
}

size_t pm_encode_command(uint8_t opcode, uint32_t arg, uint8_t *out)
{
    out[0] = PM_SYNC0;
    out[1] = PM_SYNC1;
    out[2] = PM_VERSION;
    out[3] = PM_TYPE_COMMAND;
    out[4] = opcode;
    pm_put_u32le(out + 5, arg);
    pm_put_u16le(out + 9, pm_crc16(out + 2, 7));
    return PM_CMD_LEN;
}

size_t pm_encode_reply(uint32_t seq, uint32_t t_us, uint8_t opcode, uint8_t status,
                       const char *text, size_t text_len, uint8_t *out)
{
    uint8_t *payload = out + PM_HEADER_LEN;
    if (text_len > PM_REPLY_TEXT_MAX)
        text_len = PM_REPLY_TEXT_MAX;
    payload[0] = opcode;
    payload[1] = status;
    for (size_t k = 0; k < text_len; k++)
        payload[2 + k] = (uint8_t)text[k];
    return pm_v2_seal(PM_TYPE_REPLY, seq, t_us, 0, 0, (uint16_t)(2 + text_len), out);
}
