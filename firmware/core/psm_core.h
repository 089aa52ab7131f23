/* PSM device logic (docs/spec.md §5, docs/protocol.md): scan sequencing, framing, commands.
 * Hardware lives behind psm_hal; the same code runs on the BluePill, in the host unit
 * tests and in the digital twin. No floats, no malloc: the caller allocates psm_core. */
#ifndef PSMAT_PSM_CORE_H
#define PSMAT_PSM_CORE_H

#include <stddef.h>
#include <stdint.h>

#include "command.h"
#include "device.h"
#include "frame.h"

/* Buffer limits; a target may lower them (the BluePill's 4-bit muxes stop at 16x16). */
#ifndef PSM_MAX_ROWS
#define PSM_MAX_ROWS 64
#endif
#ifndef PSM_MAX_COLS
#define PSM_MAX_COLS 64
#endif
#define PSM_MAX_CELLS (PSM_MAX_ROWS * PSM_MAX_COLS)
#define PSM_FRAME_MAX PM_V2_LEN(2u * PSM_MAX_CELLS) /* v2 is the longer framing */

#define PSM_FW_VERSION "0.1.0"
#define PSM_DEFAULT_RATE_HZ 100u
#define PSM_RATE_MIN 1u
#define PSM_RATE_MAX 1000u
#define PSM_ADC_MASK 0x0FFFu /* 12-bit counts keep 0xFF 0xFF out of v1 frames */
#define PSM_SERIAL_MAX PM_DEV_SERIAL_MAX

typedef struct psm_hal {
    void *ctx;
    void (*set_row)(void *ctx, uint8_t mux_addr); /* row mux address = R-1-i (Code 2.5) */
    void (*set_col)(void *ctx, uint8_t mux_addr); /* col mux address = p */
    uint16_t (*read_adc)(void *ctx);              /* one 12-bit conversion of the selected pair */
    void (*write)(void *ctx, const uint8_t *data, size_t n);
    uint32_t (*micros)(void *ctx);
    void (*set_rate)(void *ctx, uint32_t hz); /* retime the scan timer */
} psm_hal;

typedef struct psm_core {
    psm_hal hal;
    pm_device dev; /* protocol, streaming, rate_hz, seq, serial, parser, reply */
    uint8_t rows, cols;
    uint32_t hold;     /* CAL_HOLD argument (row << 8 | col) or PM_CAL_RESUME */
    /* board description for IDENTIFY; psm_init sets the thesis board, the caller may edit */
    uint32_t r_o_ohm;
    uint16_t v_ref_mv;
    uint16_t cells[PSM_MAX_CELLS]; /* last scan, row-major a = i*C + p */
    uint8_t frame[PSM_FRAME_MAX];
} psm_core;

/* rows/cols are clamped to [1, PSM_MAX_*]; a protocol other than 1 selects v2. Streaming
 * starts at once (thesis behaviour); the caller's timer runs at PSM_DEFAULT_RATE_HZ. */
void psm_init(psm_core *c, const psm_hal *hal, uint8_t rows, uint8_t cols, uint8_t protocol,
              const char *serial);
/* Timer IRQ: while streaming, scan all cells (or the CAL_HOLD pair), encode, write. */
void psm_on_tick(psm_core *c);
/* Host bytes, any chunking -> commands -> one reply each. */
void psm_on_rx(psm_core *c, const uint8_t *data, size_t n);

#endif
