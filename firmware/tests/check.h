/* Minimal host test harness: each test executable counts failed checks and exits non-zero
 * if any failed, printing file:line for each. */
#ifndef PSMAT_CHECK_H
#define PSMAT_CHECK_H

#include <stdio.h>
#include <string.h>

static int check_failures;

#define CHECK(cond)                                                                        \
    do {                                                                                   \
        if (!(cond)) {                                                                     \
            check_failures++;                                                              \
            fprintf(stderr, "%s:%d: CHECK(%s) failed\n", __FILE__, __LINE__, #cond);       \
        }                                                                                  \
    } while (0)

#define CHECK_EQ(got, want)                                                                \
    do {                                                                                   \
        unsigned long g_ = (unsigned long)(got), w_ = (unsigned long)(want);               \
        if (g_ != w_) {                                                                    \
            check_failures++;                                                              \
            fprintf(stderr, "%s:%d: %s == 0x%lx, want 0x%lx\n", __FILE__, __LINE__, #got,  \
                    g_, w_);                                                               \
        }                                                                                  \
    } while (0)

/* n bytes of got equal want (an array literal) */
#define CHECK_BYTES(got, want, n)                                                          \
    do {                                                                                   \
        if (memcmp((got), (want), (n)) != 0) {                                             \
            check_failures++;                                                              \
            fprintf(stderr, "%s:%d: bytes of %s differ from %s\n", __FILE__, __LINE__,     \
                    #got, #want);                                                          \
        }                                                                                  \
    } while (0)

static int check_report(const char *name)
{
    if (check_failures)
        fprintf(stderr, "%s: %d check(s) FAILED\n", name, check_failures);
    else
        printf("%s: ok\n", name);
    return check_failures ? 1 : 0;
}

#endif
