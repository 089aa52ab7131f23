#include "uid.h"

#include "regs.h"

void uid_serial(char out[9])
{
    static const char hex[] = "0123456789ABCDEF";
    uint32_t id = UID[0] ^ UID[1] ^ UID[2];
    for (int k = 7; k >= 0; k--, id >>= 4)
        out[k] = hex[id & 0xFu];
    out[8] = '\0';
}
