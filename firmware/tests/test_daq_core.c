/* daq_core: text lines (docs/protocol.md "Material DAQ"), 's' / 'f'. */
#include "check.h"
#include "daq_core.h"

/* ---- fake hardware ----------------------------------------------------------------- */
typedef struct fake {
    uint8_t selected;
    uint16_t counts[DAQ_SENSORS];
    char out[512];
    size_t out_len, n_writes;
} fake;

static void f_select(void *ctx, uint8_t s) { ((fake *)ctx)->selected = s; }
static uint16_t f_read_adc(void *ctx)
{
    fake *f = ctx;
    return f->counts[f->selected];
}
static void f_write(void *ctx, const uint8_t *data, size_t n)
{
    fake *f = ctx;
    memcpy(f->out + f->out_len, data, n);
    f->out_len += n;
    f->out[f->out_len] = '\0';
    f->n_writes++;
}

static fake F = {0, {512, 498, 1023, 0, 77, 301, 290, 288, 1001, 12}, {0}, 0, 0};
static daq_core C;
/* ------------------------------------------------------------------------------------ */

int main(void)
{
    daq_hal hal = {&F, f_select, f_read_adc, f_write};
    daq_init(&C, &hal);

    daq_on_tick(&C); /* idle until 's' */
    CHECK_EQ(F.n_writes, 0);

    daq_on_rx(&C, (const uint8_t *)"xs", 2);
    daq_on_tick(&C);
    CHECK(strcmp(F.out, "512,498,1023,0,77,301,290,288,1001,12\r\n") == 0);

    F.counts[0] = 0xFC01; /* only the 10 ADC bits are reported */
    F.out_len = 0;
    daq_on_tick(&C);
    CHECK(strcmp(F.out, "1,498,1023,0,77,301,290,288,1001,12\r\n") == 0);

    daq_on_rx(&C, (const uint8_t *)"?f", 2);
    daq_on_tick(&C);
    CHECK_EQ(F.n_writes, 2);

    for (uint8_t s = 0; s < DAQ_SENSORS; s++)
        F.counts[s] = 1023;
    daq_on_rx(&C, (const uint8_t *)"s", 1);
    F.out_len = 0;
    daq_on_tick(&C); /* the longest line fits DAQ_LINE_MAX */
    CHECK_EQ(F.out_len, DAQ_LINE_MAX);
    CHECK(strcmp(F.out + DAQ_LINE_MAX - 6, "1023\r\n") == 0);
    return check_report("test_daq_core");
}
