#ifndef PSMAT_RING_H
#define PSMAT_RING_H
/* Single-producer single-consumer byte ring (portable: compiles and is tested on the host).
 * head and tail run freely and wrap at 2^32; size is a power of two, so used = head - tail.
 * The producer only writes head, the consumer only writes tail, so one producer context and
 * one consumer context need no lock on a single-core MCU (32-bit stores are atomic). */
#include <stddef.h>
#include <stdint.h>

typedef struct {
    uint8_t *buf;
    uint32_t size; /* power of two */
    volatile uint32_t head, tail;
} pm_ring;

void ring_init(pm_ring *r, uint8_t *buf, uint32_t size);
uint32_t ring_used(const pm_ring *r);
uint32_t ring_free(const pm_ring *r);
/* Producer: queues all n bytes and returns n, or queues nothing and returns 0 if they do
 * not fit (a frame is never split). */
size_t ring_write_all(pm_ring *r, const uint8_t *data, size_t n);
/* Consumer: takes up to max bytes, returns how many. */
size_t ring_read(pm_ring *r, uint8_t *data, size_t max);
/* Consumer: drops everything queued so far. */
void ring_flush(pm_ring *r);
#endif
