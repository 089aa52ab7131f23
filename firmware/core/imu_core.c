#include "imu_core.h"

#include "text.h"

void imu_init(imu_core *c, const imu_hal *hal, uint8_t protocol, const char *serial)
{
    uint8_t k = 0;
    c->hal = *hal;
    c->protocol = protocol == PM_PROTO_V1 ? PM_PROTO_V1 : PM_PROTO_V2;
    c->streaming = 1;
    c->rate_hz = IMU_DEFAULT_RATE_HZ;
    c->seq = 0;
    while (serial && serial[k] && k < IMU_SERIAL_MAX) {
        c->serial[k] = serial[k];
        k++;
    }
    c->serial[k] = '\0';
    pm_cmd_parser_init(&c->parser);
}

void imu_on_tick(imu_core *c)
{
    size_t len;
    uint32_t t_us;
    if (!c->streaming)
        return;
    t_us = c->hal.micros(c->hal.ctx);
    for (uint8_t s = 0; s < IMU_SENSORS; s++)
        c->hal.read_euler(c->hal.ctx, s, &c->angles[3u * s]);
    if (c->protocol == PM_PROTO_V1)
        len = imu_encode_v1(c->angles, c->frame);
    else
        len = imu_encode_v2(c->seq, t_us, c->angles, c->frame);
    c->seq++;
    c->hal.write(c->hal.ctx, c->frame, len);
}

static size_t identify(const imu_core *c, char *buf, size_t cap)
{
    pm_text t;
    pm_text_init(&t, buf, cap);
    pm_text_str(&t, "device=imu fw=" IMU_FW_VERSION " sensors=5 rate=");
    pm_text_u32(&t, c->rate_hz);
    pm_text_str(&t, " proto=");
    pm_text_u32(&t, c->protocol);
    pm_text_str(&t, " serial=");
    pm_text_str(&t, c->serial);
    pm_text_str(&t, " units=deg");
    return t.len;
}

/* As psm_core's execute(); START, STOP and IDENTIFY take arg 0 and ignore it. */
static uint8_t execute(imu_core *c, const pm_cmd *cmd, char *text, size_t *len)
{
    uint32_t arg = cmd->arg;
    switch (cmd->opcode) {
    case PM_OP_START:
        c->streaming = 1;
        return PM_ST_OK;
    case PM_OP_STOP:
        c->streaming = 0;
        return PM_ST_OK;
    case PM_OP_SET_RATE:
        if (arg < IMU_RATE_MIN || arg > IMU_RATE_MAX)
            return PM_ST_BAD_ARG;
        c->rate_hz = arg;
        c->hal.set_rate(c->hal.ctx, arg);
        return PM_ST_OK;
    case PM_OP_IDENTIFY:
        *len = identify(c, text, PM_REPLY_TEXT_MAX);
        return PM_ST_OK;
    case PM_OP_SET_PROTOCOL:
        if (arg != PM_PROTO_V1 && arg != PM_PROTO_V2)
            return PM_ST_BAD_ARG;
        c->protocol = (uint8_t)arg;
        return PM_ST_OK;
    default:
        return PM_ST_UNKNOWN;
    }
}

void imu_on_rx(imu_core *c, const uint8_t *data, size_t n)
{
    pm_cmd cmd;
    char text[PM_REPLY_TEXT_MAX];
    for (size_t k = 0; k < n; k++) {
        size_t len = 0;
        uint8_t status;
        if (!pm_cmd_push(&c->parser, data[k], &cmd))
            continue;
        status = execute(c, &cmd, text, &len);
        len = pm_encode_reply(c->seq, c->hal.micros(c->hal.ctx), cmd.opcode, status, text, len,
                              c->reply);
        c->hal.write(c->hal.ctx, c->reply, len);
    }
}
