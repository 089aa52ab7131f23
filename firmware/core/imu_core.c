#include "imu_core.h"

#include "text.h"

void imu_init(imu_core *c, const imu_hal *hal, uint8_t protocol, const char *serial)
{
    const pm_dev_io io = {hal->ctx, hal->write, hal->micros, hal->set_rate};
    c->hal = *hal;
    pm_dev_init(&c->dev, &io, protocol, IMU_DEFAULT_RATE_HZ, IMU_RATE_MIN, IMU_RATE_MAX, serial);
}

void imu_on_tick(imu_core *c)
{
    size_t len;
    uint32_t t_us;
    if (!c->dev.streaming)
        return;
    t_us = c->hal.micros(c->hal.ctx);
    for (uint8_t s = 0; s < IMU_SENSORS; s++)
        c->hal.read_euler(c->hal.ctx, s, &c->angles[3u * s]);
    if (c->dev.protocol == PM_PROTO_V1)
        len = imu_encode_v1(c->angles, c->frame);
    else
        len = imu_encode_v2(c->dev.seq, t_us, c->angles, c->frame);
    pm_dev_send_frame(&c->dev, c->frame, len);
}

static size_t identify(const imu_core *c, char *buf, size_t cap)
{
    pm_text t;
    pm_text_init(&t, buf, cap);
    pm_text_str(&t, "device=imu fw=" IMU_FW_VERSION " sensors=5 rate=");
    pm_text_u32(&t, c->dev.rate_hz);
    pm_text_str(&t, " proto=");
    pm_text_u32(&t, c->dev.protocol);
    pm_text_str(&t, " serial=");
    pm_text_str(&t, c->dev.serial);
    pm_text_str(&t, " units=deg");
    return t.len;
}

/* The IMU's own commands (pm_dev_execute_fn): IDENTIFY only; CAL_HOLD is unknown here. */
static uint8_t execute(void *core, const pm_cmd *cmd, char *text, size_t *len)
{
    if (cmd->opcode != PM_OP_IDENTIFY)
        return PM_ST_UNKNOWN;
    *len = identify(core, text, PM_REPLY_TEXT_MAX);
    return PM_ST_OK;
}

void imu_on_rx(imu_core *c, const uint8_t *data, size_t n)
{
    pm_dev_on_rx(&c->dev, data, n, execute, c);
}
