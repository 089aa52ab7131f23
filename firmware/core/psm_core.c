#include "psm_core.h"

#include "text.h"

void psm_init(psm_core *c, const psm_hal *hal, uint8_t rows, uint8_t cols, uint8_t protocol,
              const char *serial)
{
    const pm_dev_io io = {hal->ctx, hal->write, hal->micros, hal->set_rate};
    c->hal = *hal;
    pm_dev_init(&c->dev, &io, protocol, PSM_DEFAULT_RATE_HZ, PSM_RATE_MIN, PSM_RATE_MAX, serial);
    c->rows = rows < 1 ? 1 : rows > PSM_MAX_ROWS ? PSM_MAX_ROWS : rows;
    c->cols = cols < 1 ? 1 : cols > PSM_MAX_COLS ? PSM_MAX_COLS : cols;
    c->hold = PM_CAL_RESUME;
    c->r_o_ohm = 2200;
    c->v_ref_mv = 3300;
}

/* Code 2.5: rows through the mux at address R-1-i, columns at p; frame in logical order. */
static void scan(psm_core *c)
{
    const psm_hal *h = &c->hal;
    uint16_t *cell = c->cells;
    for (uint8_t i = 0; i < c->rows; i++) {
        h->set_row(h->ctx, (uint8_t)(c->rows - 1u - i));
        for (uint8_t p = 0; p < c->cols; p++) {
            h->set_col(h->ctx, p);
            *cell++ = (uint16_t)(h->read_adc(h->ctx) & PSM_ADC_MASK);
        }
    }
}

/* CAL_HOLD: one row-column pair, read once per cell slot so the frame keeps its shape. */
static void scan_held(psm_core *c)
{
    const psm_hal *h = &c->hal;
    size_t n_cells = (size_t)c->rows * c->cols;
    h->set_row(h->ctx, (uint8_t)(c->rows - 1u - (uint8_t)(c->hold >> 8)));
    h->set_col(h->ctx, (uint8_t)c->hold);
    for (size_t a = 0; a < n_cells; a++)
        c->cells[a] = (uint16_t)(h->read_adc(h->ctx) & PSM_ADC_MASK);
}

void psm_on_tick(psm_core *c)
{
    size_t len;
    uint32_t t_us;
    if (!c->dev.streaming)
        return;
    t_us = c->hal.micros(c->hal.ctx);
    if (c->hold == PM_CAL_RESUME)
        scan(c);
    else
        scan_held(c);
    if (c->dev.protocol == PM_PROTO_V1)
        len = psm_encode_v1(c->cells, (size_t)c->rows * c->cols, c->frame);
    else
        len = psm_encode_v2(c->dev.seq, t_us, c->rows, c->cols, c->cells, c->frame);
    pm_dev_send_frame(&c->dev, c->frame, len);
}

static size_t identify(const psm_core *c, char *buf, size_t cap)
{
    pm_text t;
    pm_text_init(&t, buf, cap);
    pm_text_str(&t, "device=psm fw=" PSM_FW_VERSION " rows=");
    pm_text_u32(&t, c->rows);
    pm_text_str(&t, " cols=");
    pm_text_u32(&t, c->cols);
    pm_text_str(&t, " rate=");
    pm_text_u32(&t, c->dev.rate_hz);
    pm_text_str(&t, " proto=");
    pm_text_u32(&t, c->dev.protocol);
    pm_text_str(&t, " serial=");
    pm_text_str(&t, c->dev.serial);
    pm_text_str(&t, " r_o=");
    pm_text_u32(&t, c->r_o_ohm);
    pm_text_str(&t, " v_ref=");
    pm_text_milli(&t, c->v_ref_mv);
    pm_text_str(&t, " bits=12");
    return t.len;
}

/* The PSM's own commands (pm_dev_execute_fn); device.c handles the shared ones. */
static uint8_t execute(void *core, const pm_cmd *cmd, char *text, size_t *len)
{
    psm_core *c = core;
    uint32_t arg = cmd->arg;
    switch (cmd->opcode) {
    case PM_OP_IDENTIFY:
        *len = identify(c, text, PM_REPLY_TEXT_MAX);
        return PM_ST_OK;
    case PM_OP_CAL_HOLD:
        if (arg != PM_CAL_RESUME && (arg > 0xFFFFu || (arg >> 8) >= c->rows ||
                                     (arg & 0xFFu) >= c->cols))
            return PM_ST_BAD_ARG;
        c->hold = arg;
        return PM_ST_OK;
    default:
        return PM_ST_UNKNOWN;
    }
}

void psm_on_rx(psm_core *c, const uint8_t *data, size_t n)
{
    pm_dev_on_rx(&c->dev, data, n, execute, c);
}
