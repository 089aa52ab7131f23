/* Bounded ASCII builder for reply texts and DAQ lines: no printf on the MCUs. Output is
 * truncated (never overrun) at `cap`; there is no terminating NUL. */
#ifndef PSMAT_TEXT_H
#define PSMAT_TEXT_H

#include <stddef.h>
#include <stdint.h>

typedef struct pm_text {
    char *buf;
    size_t len;
    size_t cap;
} pm_text;

void pm_text_init(pm_text *t, char *buf, size_t cap);
void pm_text_char(pm_text *t, char ch);
void pm_text_str(pm_text *t, const char *s);
void pm_text_u32(pm_text *t, uint32_t v);
/* milli / 1000 in decimal with at least one fractional digit: 3300 -> "3.3" */
void pm_text_milli(pm_text *t, uint32_t milli);

#endif
