"""psmat.acquire ring buffer, host clock and stream decoder (no I/O)."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from psmat.acquire import FrameBatch, FrameRing, HostClock, StreamDecoder
from psmat.protocol import Opcode, Status, encode_daq_line, encode_reply, encode_v1, encode_v2
from hang_guard import WAIT_LONGER_S, returns


def _push(ring: FrameRing, start: int, n: int) -> int:
    idx = np.arange(start, start + n)
    frames = np.broadcast_to(idx[:, None, None], (n, 2, 3)).astype(np.uint16)
    return ring.push(frames, idx * 0.01, idx % 2 == 0, idx, idx * 1000)


def test_push_pop_in_order_across_the_wrap() -> None:
    ring = FrameRing(5, (2, 3), np.uint16)
    assert _push(ring, 0, 3) == 0
    b = ring.pop(2)
    np.testing.assert_array_equal(b.seq, [0, 1])
    assert _push(ring, 3, 4) == 0          # wraps around the end of the arrays
    assert len(ring) == 5
    b = ring.pop()
    np.testing.assert_array_equal(b.seq, [2, 3, 4, 5, 6])
    np.testing.assert_array_equal(b.frames[:, 1, 2], [2, 3, 4, 5, 6])
    np.testing.assert_array_equal(b.valid, [True, False, True, False, True])
    np.testing.assert_allclose(b.host_time_s, [0.02, 0.03, 0.04, 0.05, 0.06])
    np.testing.assert_array_equal(b.device_time_us, [2000, 3000, 4000, 5000, 6000])
    assert len(ring.pop()) == 0 and ring.dropped == 0 and ring.pushed == 7


def test_overflow_drops_the_oldest_and_counts() -> None:
    ring = FrameRing(4, (2, 3), np.uint16)
    _push(ring, 0, 3)
    assert _push(ring, 3, 3) == 2
    assert _push(ring, 6, 10) == 10        # more than the capacity in one push
    assert ring.dropped == 12 and len(ring) == 4
    np.testing.assert_array_equal(ring.pop().seq, [12, 13, 14, 15])


def test_latest_does_not_consume_and_returns_copies() -> None:
    ring = FrameRing(8, (2, 3), np.uint16)
    _push(ring, 0, 6)
    last = ring.latest(2)
    np.testing.assert_array_equal(last.seq, [4, 5])
    last.frames[:] = 99
    assert len(ring) == 6 and ring.latest(100).seq.tolist() == [0, 1, 2, 3, 4, 5]
    assert int(ring.pop(1).frames.max()) == 0


def test_wait_for_times_out_and_is_woken_by_a_push() -> None:
    ring = FrameRing(8, (2, 3), np.uint16)
    t0 = time.monotonic()
    assert ring.wait_for(1, 0.1) == 0
    assert time.monotonic() >= t0 + 0.1       # it waited its whole timeout (a lower bound only)
    # woken, not timed out: the waits' own timeouts outlast the hang guard
    threading.Timer(0.05, _push, (ring, 0, 3)).start()
    assert returns(lambda: ring.wait_for(3, WAIT_LONGER_S), "wait_for woken by a push") == 3
    flag = []
    threading.Timer(0.05, lambda: (flag.append(1), ring.wake())).start()
    assert returns(lambda: ring.wait_for(100, WAIT_LONGER_S, stop=lambda: bool(flag)), "wake() with stop true") == 3


def test_ring_rejects_zero_capacity_and_empty_batch() -> None:
    with pytest.raises(ValueError):
        FrameRing(0, (2,), np.uint16)
    b = FrameBatch.empty((16, 16), np.uint16)
    assert len(b) == 0 and b.frames.shape == (0, 16, 16)


def test_host_clock_follows_monotonic_not_wall_steps() -> None:
    wall = iter([1000.0]).__next__
    mono_values = iter([5.0, 5.5, 7.0])
    clock = HostClock(wall=wall, mono=lambda: next(mono_values))
    assert clock.now() == 1000.5
    assert clock.now() == 1002.0
    # the default sources are time.time and time.monotonic: now() lies between two wall readings
    # (no wall step in between; 1e-6 s covers float rounding at 1.7e9 s, ulp 2.4e-7 s)
    before = time.time()
    real = HostClock()
    now = real.now()
    after = time.time()
    assert before <= now <= after + 1e-6


def test_stream_decoder_counts_and_follows_a_protocol_switch() -> None:
    dec = StreamDecoder("psm", 2, (4, 4))
    f = np.arange(16, dtype=np.uint16).reshape(4, 4)
    rows = dec.feed(encode_v2(f, 0, 0) + encode_v2(np.ones((2, 2), int), 1, 10))
    assert len(rows) == 1 and dec.counters["mismatched"] == 1
    dec.expect_protocol_switch(1)
    stream = encode_reply(Opcode.SET_PROTOCOL, Status.OK) + encode_v1(f) + encode_v1(f + 1)
    out = dec.feed(stream[:30])
    out += dec.feed(stream[30:])
    assert dec.protocol == 1
    frames = [r for r in out if hasattr(r, "valid")]
    assert len(frames) == 2 and frames[1].data[0, 0] == 1 and frames[1].seq == -1
    c = dec.counters
    assert (c["frames"], c["replies"], c["invalid"], c["skipped"]) == (3, 1, 0, 0)
    assert c["bytes_in"] == len(encode_v2(f, 0, 0)) + 26 + len(stream)


def test_stream_decoder_daq_malformed_lines_are_invalid_rows() -> None:
    dec = StreamDecoder("daq", 2, (10,))
    good = encode_daq_line(np.arange(10))
    rows = dec.feed(good + b"1,2,3\r\n" + good[:5])
    rows += dec.feed(good[5:])
    assert [r.valid for r in rows] == [True, False, True]
    assert rows[0].data.dtype == np.uint16 and rows[1].data.shape == (10,)
    assert dec.counters["invalid"] == 1 and dec.counters["frames"] == 2


def test_stream_decoder_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError):
        StreamDecoder("mat", 2, (16, 16))
    with pytest.raises(ValueError):
        StreamDecoder("psm", 3, (16, 16))
