#include "device.h"

void pm_dev_init(pm_device *d, const pm_dev_io *io, uint8_t protocol, uint32_t rate_hz,
                 uint32_t rate_min, uint32_t rate_max, const char *serial)
{
    uint8_t k = 0;
    d->io = *io;
    d->protocol = protocol == PM_PROTO_V1 ? PM_PROTO_V1 : PM_PROTO_V2;
    d->streaming = 1;
    d->rate_hz = rate_hz;
    d->rate_min = rate_min;
    d->rate_max = rate_max;
    d->seq = 0;
    while (serial && serial[k] && k < PM_DEV_SERIAL_MAX) {
        d->serial[k] = serial[k];
        k++;
    }
    d->serial[k] = '\0';
    pm_cmd_parser_init(&d->parser);
}

void pm_dev_send_frame(pm_device *d, const uint8_t *frame, size_t len)
{
    d->seq++;
    d->io.write(d->io.ctx, frame, len);
}

/* The shared commands; anything else goes to the core's execute(). */
static uint8_t execute_common(pm_device *d, const pm_cmd *cmd, pm_dev_execute_fn execute,
                              void *core, char *text, size_t *len)
{
    uint32_t arg = cmd->arg;
    switch (cmd->opcode) {
    case PM_OP_START:
        d->streaming = 1;
        return PM_ST_OK;
    case PM_OP_STOP:
        d->streaming = 0;
        return PM_ST_OK;
    case PM_OP_SET_RATE:
        if (arg < d->rate_min || arg > d->rate_max)
            return PM_ST_BAD_ARG;
        d->rate_hz = arg;
        d->io.set_rate(d->io.ctx, arg);
        return PM_ST_OK;
    case PM_OP_SET_PROTOCOL:
        if (arg != PM_PROTO_V1 && arg != PM_PROTO_V2)
            return PM_ST_BAD_ARG;
        d->protocol = (uint8_t)arg;
        return PM_ST_OK;
    default:
        return execute(core, cmd, text, len);
    }
}

void pm_dev_on_rx(pm_device *d, const uint8_t *data, size_t n, pm_dev_execute_fn execute,
                  void *core)
{
    pm_cmd cmd;
    char text[PM_REPLY_TEXT_MAX];
    for (size_t k = 0; k < n; k++) {
        size_t len = 0;
        uint8_t status;
        if (!pm_cmd_push(&d->parser, data[k], &cmd))
            continue;
        status = execute_common(d, &cmd, execute, core, text, &len);
        len = pm_encode_reply(d->seq, d->io.micros(d->io.ctx), cmd.opcode, status, text, len,
                              d->reply);
        d->io.write(d->io.ctx, d->reply, len);
    }
}
