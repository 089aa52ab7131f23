/* Host -> device commands and device -> host replies (docs/protocol.md, "Host -> device
 * commands"). Command packet, 11 bytes:
 *   A5 5A | 02 | 10 | opcode | arg u32 LE | CRC-16/CCITT-FALSE over bytes [2, 9) LE */
#ifndef PSMAT_COMMAND_H
#define PSMAT_COMMAND_H

#include <stddef.h>
#include <stdint.h>

#include "frame.h"

#define PM_CMD_LEN 11u

enum pm_opcode {
    PM_OP_START = 0x01,
    PM_OP_STOP = 0x02,
    PM_OP_SET_RATE = 0x03,
    PM_OP_IDENTIFY = 0x04,
    PM_OP_SET_PROTOCOL = 0x05,
    PM_OP_CAL_HOLD = 0x06
};

enum pm_status { PM_ST_OK = 0, PM_ST_BAD_ARG = 1, PM_ST_UNKNOWN = 2 };

#define PM_CAL_RESUME 0xFFFFFFFFu

/* Reply: v2 packet type 0x11, rows = cols = 0, payload opcode | status | text. */
#define PM_REPLY_TEXT_MAX 160u
#define PM_REPLY_MAX PM_V2_LEN(2u + PM_REPLY_TEXT_MAX)

typedef struct pm_cmd {
    uint8_t opcode;
    uint32_t arg;
} pm_cmd;

/* Incremental parser. The state is the number of bytes of a plausible command prefix held
 * in buf (0 = searching for the first sync byte, 1 = for the second, 2 = version, 3 = type,
 * 4..10 = body). Any mismatch or CRC failure drops buf[0] and re-examines the rest, so the
 * parser resyncs one byte at a time and never loses a command that starts inside garbage. */
typedef struct pm_cmd_parser {
    uint8_t buf[PM_CMD_LEN];
    uint8_t len;
} pm_cmd_parser;

void pm_cmd_parser_init(pm_cmd_parser *p);
/* Feeds one byte; returns 1 and fills *cmd when it completes a CRC-valid command. */
int pm_cmd_push(pm_cmd_parser *p, uint8_t byte, pm_cmd *cmd);

/* The host's side (tests, the digital twin): writes the 11-byte command. */
size_t pm_encode_command(uint8_t opcode, uint32_t arg, uint8_t *out);

/* Reply packet; text_len is clipped to PM_REPLY_TEXT_MAX. out needs PM_REPLY_MAX bytes. */
size_t pm_encode_reply(uint32_t seq, uint32_t t_us, uint8_t opcode, uint8_t status,
                       const char *text, size_t text_len, uint8_t *out);

#endif
