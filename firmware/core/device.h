/* State and command handling shared by the PSM and IMU cores (docs/protocol.md, "Host ->
 * device commands"): streaming flag, rate, framing, frame counter, serial, command parser
 * and reply. START, STOP, SET_RATE and SET_PROTOCOL are handled here; each core answers
 * IDENTIFY and its own opcodes (CAL_HOLD) through a callback. */
#ifndef PSMAT_DEVICE_H
#define PSMAT_DEVICE_H

#include <stddef.h>
#include <stdint.h>

#include "command.h"

#define PM_DEV_SERIAL_MAX 16u

/* The part of a core's HAL the shared code drives; copied from it at init. */
typedef struct pm_dev_io {
    void *ctx;
    void (*write)(void *ctx, const uint8_t *data, size_t n);
    uint32_t (*micros)(void *ctx);
    void (*set_rate)(void *ctx, uint32_t hz);
} pm_dev_io;

typedef struct pm_device {
    pm_dev_io io;
    uint8_t protocol;            /* PM_PROTO_V1 or PM_PROTO_V2 */
    uint8_t streaming;           /* frames are written only while set */
    uint32_t rate_hz;            /* last rate given to io.set_rate (reported by IDENTIFY) */
    uint32_t rate_min, rate_max; /* SET_RATE range, inclusive */
    uint32_t seq;                /* frames sent so far = seq of the next frame */
    char serial[PM_DEV_SERIAL_MAX + 1];
    pm_cmd_parser parser;
    uint8_t reply[PM_REPLY_MAX];
} pm_device;

/* A core's own commands (IDENTIFY and any device-specific opcode): returns the status and
 * leaves any reply text in text[0..*len) (room for PM_REPLY_TEXT_MAX); PM_ST_UNKNOWN for an
 * opcode it does not know. */
typedef uint8_t (*pm_dev_execute_fn)(void *core, const pm_cmd *cmd, char *text, size_t *len);

/* A protocol other than 1 selects v2; streaming starts at once at rate_hz; the serial is
 * cut to PM_DEV_SERIAL_MAX characters (NULL gives ""). */
void pm_dev_init(pm_device *d, const pm_dev_io *io, uint8_t protocol, uint32_t rate_hz,
                 uint32_t rate_min, uint32_t rate_max, const char *serial);
/* Writes one encoded frame and counts it. */
void pm_dev_send_frame(pm_device *d, const uint8_t *frame, size_t len);
/* Host bytes, any chunking -> commands -> one reply each; opcodes other than the shared
 * ones go to execute(core, ...). START, STOP and IDENTIFY take arg 0 and ignore it. */
void pm_dev_on_rx(pm_device *d, const uint8_t *data, size_t n, pm_dev_execute_fn execute,
                  void *core);

#endif
