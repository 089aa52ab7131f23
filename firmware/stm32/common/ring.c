#include "ring.h"

/* Orders the byte copies before the index store that publishes them (compiler barrier;
 * the Cortex-M3 does not reorder stores to normal memory as seen by its own interrupts). */
#define PUBLISH() __asm__ volatile("" ::: "memory")

void ring_init(pm_ring *r, uint8_t *buf, uint32_t size)
{
    r->buf = buf;
    r->size = size;
    r->head = r->tail = 0;
}

uint32_t ring_used(const pm_ring *r) { return r->head - r->tail; }

uint32_t ring_free(const pm_ring *r) { return r->size - (r->head - r->tail); }

size_t ring_write_all(pm_ring *r, const uint8_t *data, size_t n)
{
    uint32_t head = r->head, mask = r->size - 1u;
    if (n > (size_t)(r->size - (head - r->tail)))
        return 0;
    for (size_t k = 0; k < n; k++)
        r->buf[(head + (uint32_t)k) & mask] = data[k];
    PUBLISH();
    r->head = head + (uint32_t)n;
    return n;
}

size_t ring_read(pm_ring *r, uint8_t *data, size_t max)
{
    uint32_t tail = r->tail, mask = r->size - 1u;
    uint32_t avail = r->head - tail;
    size_t n = max < avail ? max : avail;
    PUBLISH();
    for (size_t k = 0; k < n; k++)
        data[k] = r->buf[(tail + (uint32_t)k) & mask];
    PUBLISH();
    r->tail = tail + (uint32_t)n;
    return n;
}

void ring_flush(pm_ring *r) { r->tail = r->head; }
