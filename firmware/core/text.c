#include "text.h"

void pm_text_init(pm_text *t, char *buf, size_t cap)
{
    t->buf = buf;
    t->len = 0;
    t->cap = cap;
}

void pm_text_char(pm_text *t, char ch)
{
    if (t->len < t->cap)
        t->buf[t->len++] = ch;
}

void pm_text_str(pm_text *t, const char *s)
{
    while (*s)
        pm_text_char(t, *s++);
}

void pm_text_u32(pm_text *t, uint32_t v)
{
    char digits[10];
    int k = 0;
    do {
        digits[k++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v);
    while (k)
        pm_text_char(t, digits[--k]);
}

void pm_text_milli(pm_text *t, uint32_t milli)
{
    uint32_t frac = milli % 1000u;
    pm_text_u32(t, milli / 1000u);
    pm_text_char(t, '.');
    pm_text_char(t, (char)('0' + frac / 100u));
    if (frac % 100u) {
        pm_text_char(t, (char)('0' + frac / 10u % 10u));
        if (frac % 10u)
            pm_text_char(t, (char)('0' + frac % 10u));
    }
}
