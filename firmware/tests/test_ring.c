/* pm_ring (stm32/common/ring.c): all-or-nothing writes, wrap, overflow, flush, and the
 * free-running indices across 2^32. */
#include "check.h"
#include "ring.h"

int main(void)
{
    uint8_t mem[16], out[32], frame[10];
    pm_ring r;
    for (unsigned k = 0; k < sizeof frame; k++)
        frame[k] = (uint8_t)(0xA0 + k);

    ring_init(&r, mem, sizeof mem);
    CHECK_EQ(ring_used(&r), 0);
    CHECK_EQ(ring_free(&r), 16);
    CHECK_EQ(ring_read(&r, out, sizeof out), 0);

    /* a 10-byte frame fits, a second does not: dropped whole, nothing half-written */
    CHECK_EQ(ring_write_all(&r, frame, 10), 10);
    CHECK_EQ(ring_write_all(&r, frame, 10), 0);
    CHECK_EQ(ring_used(&r), 10);
    CHECK_EQ(ring_read(&r, out, 4), 4); /* partial read */
    CHECK_BYTES(out, frame, 4);
    CHECK_EQ(ring_free(&r), 10);

    /* now 10 fit again and wrap around the end of the buffer */
    CHECK_EQ(ring_write_all(&r, frame, 10), 10);
    CHECK_EQ(ring_used(&r), 16);
    CHECK_EQ(ring_free(&r), 0);
    CHECK_EQ(ring_write_all(&r, frame, 1), 0); /* full: overflow drops */
    CHECK_EQ(ring_read(&r, out, sizeof out), 16);
    CHECK_BYTES(out, frame + 4, 6);
    CHECK_BYTES(out + 6, frame, 10);
    CHECK_EQ(ring_used(&r), 0);

    /* exactly the size fits; one more byte than the size never does */
    CHECK_EQ(ring_write_all(&r, mem, 17), 0);
    {
        uint8_t big[16];
        for (unsigned k = 0; k < 16; k++)
            big[k] = (uint8_t)k;
        CHECK_EQ(ring_write_all(&r, big, 16), 16);
        CHECK_EQ(ring_read(&r, out, 16), 16);
        CHECK_BYTES(out, big, 16);
    }

    /* flush drops what is queued */
    CHECK_EQ(ring_write_all(&r, frame, 5), 5);
    ring_flush(&r);
    CHECK_EQ(ring_used(&r), 0);
    CHECK_EQ(ring_free(&r), 16);

    /* indices that wrap at 2^32 keep used/free right */
    r.head = r.tail = 0xFFFFFFF8u;
    CHECK_EQ(ring_write_all(&r, frame, 10), 10);
    CHECK(r.head < r.tail);
    CHECK_EQ(ring_used(&r), 10);
    CHECK_EQ(ring_free(&r), 6);
    CHECK_EQ(ring_write_all(&r, frame, 7), 0);
    CHECK_EQ(ring_read(&r, out, sizeof out), 10);
    CHECK_BYTES(out, frame, 10);

    /* zero-length write is a no-op that "succeeds" with 0 */
    CHECK_EQ(ring_write_all(&r, frame, 0), 0);
    CHECK_EQ(ring_used(&r), 0);

    /* a 2048-byte ring holds three 530-byte frames, the fourth is dropped */
    {
        static uint8_t big_mem[2048], f[530];
        pm_ring b;
        unsigned ok = 0;
        ring_init(&b, big_mem, sizeof big_mem);
        for (int k = 0; k < 4; k++)
            ok += ring_write_all(&b, f, sizeof f) == sizeof f;
        CHECK_EQ(ok, 3);
        CHECK_EQ(ring_used(&b), 3 * 530);
    }
    return check_report("test_ring");
}
