"""Incremental decoders under corruption: bit flips, dropped bytes, garbage, random chunking.

The expectations are derived from what each corruption does to the bytes (which sent frames
were touched), never from the decoder's own output.
"""

from __future__ import annotations

import numpy as np
import pytest

from psmat.protocol import (Frame, Gap, ImuV1Decoder, Reply, V1Decoder, V2Decoder, encode_imu_v1, encode_reply,
                            encode_v1, encode_v2)

WRAP = 2**32


def feed_chunks(dec, data: bytes, rng) -> list:
    """Feed ``data`` in random chunks (many tiny, some up to 4 KiB), then finish."""
    events = []
    i = 0
    while i < len(data):
        step = int(rng.integers(1, 17)) if rng.random() < 0.5 else int(rng.integers(1, 4097))
        events += dec.feed(data[i:i + step])
        i += step
    return events + dec.finish()


def corrupt(packets: list[bytes], rng, n_events: int, ops: tuple[str, ...], protect: int = 0,
            head: int = 1, tail: int = 2, spaced: bool = False, marker_free_garbage: bool = False):
    """Corrupt ``n_events`` distinct packets (not the first ``head`` nor the last ``tail``).

    ``protect``: leading bytes of each packet (the marker) left alone by flips, drops and
    insertions inside a packet. ``spaced``: no two corrupted packets are adjacent.
    ``marker_free_garbage``: inserted garbage holds no 0xFF (so it cannot fake a v1 marker).
    Returns the stream, the set of touched packet indices and the number of garbage insertions
    placed between packets.
    """
    pieces = [bytearray(p) for p in packets]
    touched: set[int] = set()
    between = 0
    if spaced:
        idx = 2 * rng.choice(np.arange((head + 1) // 2, (len(packets) - tail) // 2), size=n_events, replace=False)
    else:
        idx = rng.choice(np.arange(head, len(packets) - tail), size=n_events, replace=False)
    for i in sorted(int(v) for v in idx):
        p = pieces[i]
        op = ops[int(rng.integers(len(ops)))]
        if op == "flip":
            pos = int(rng.integers(protect, len(p)))
            p[pos] ^= 1 << int(rng.integers(8))
            touched.add(i)
        elif op == "drop":
            pos = int(rng.integers(protect, len(p)))
            del p[pos:pos + int(rng.integers(1, 4))]
            touched.add(i)
        elif op == "burst":
            pos = int(rng.integers(protect, len(p)))
            k = int(rng.integers(2, 12))
            p[pos:pos + k] = rng.integers(0, 256, k, dtype=np.uint8).tobytes()[:len(p) - pos]
            touched.add(i)
        elif op == "insert":  # garbage inside the packet
            pos = int(rng.integers(max(1, protect), len(p)))
            garbage = rng.integers(0, 256, int(rng.integers(1, 40)), dtype=np.uint8)
            if marker_free_garbage:
                garbage[garbage == 0xFF] = 0
            p[pos:pos] = garbage.tobytes()
            touched.add(i)
        elif op == "garbage":  # garbage between packets i-1 and i (touches neither)
            p[0:0] = rng.integers(0, 256, int(rng.integers(1, 40)), dtype=np.uint8).tobytes()
            between += 1
        else:  # pragma: no cover
            raise AssertionError(op)
    # a packet whose original bytes still lie contiguous in its piece is intact (e.g. garbage
    # inserted right after a first 0xA5 that itself ends in 0xA5 recreates the sync)
    touched = {i for i in touched if bytes(packets[i]) not in pieces[i]}
    return b"".join(bytes(p) for p in pieces), touched, between


def psm_frames(rng, n, shape):
    frames = rng.integers(0, 4096, (n, *shape))
    # plenty of 0x?FF cells (lo byte 0xFF) and 0x0FFF to stress the marker search
    mask = rng.random(frames.shape) < 0.1
    frames[mask] = 0x0FFF
    return frames


# --- v1 PSM ------------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("shape", [(16, 16), (3, 5)])
def test_v1_time_base_kept_under_flips_and_drops(seed, shape):
    """Corruption after the marker: one invalid row exactly where each touched frame was."""
    rng = np.random.default_rng(seed)
    n = 300
    sent = psm_frames(rng, n, shape)
    stream, touched, _ = corrupt([encode_v1(f) for f in sent], rng, 40, ("flip", "drop", "burst", "insert"),
                                 protect=2, spaced=True, marker_free_garbage=True)
    dec = V1Decoder(shape)
    events = feed_chunks(dec, stream, rng)
    rows = [e for e in events if isinstance(e, Frame)]
    assert len(rows) == n
    assert [r.valid for r in rows] == [i not in touched for i in range(n)]
    for i, r in enumerate(rows):
        if r.valid:
            np.testing.assert_array_equal(r.data, sent[i])
        else:
            assert (r.data == 0).all()
    assert dec.frames == n - len(touched) and dec.invalid == len(touched)
    assert dec.bytes_in == len(stream)


@pytest.mark.parametrize("seed", [4, 5, 6])
@pytest.mark.parametrize("shape", [(16, 16), (3, 5), (1, 1)])
def test_v1_fuzz_everything(seed, shape):
    """Any corruption, including of markers, plus garbage between frames and interleaved replies."""
    rng = np.random.default_rng(seed)
    n = 300
    sent = psm_frames(rng, n, shape)
    packets = [encode_v1(f) for f in sent]
    stream, touched, between = corrupt(packets, rng, 60, ("flip", "drop", "burst", "insert", "garbage"))
    dec = V1Decoder(shape)
    events = feed_chunks(dec, stream, rng)
    rows = [e for e in events if isinstance(e, Frame)]
    good = [r.data for r in rows if r.valid]
    clean = [sent[i] for i in range(n) if i not in touched]
    if shape == (1, 1):
        # a 1x1 frame has 4 check bits of structure only: a corrupted one may pass by chance.
        # Still: every clean frame is recovered, in order, among the valid ones.
        it = iter(good)
        assert all(any(np.array_equal(c, g) for g in it) for c in clean)
    else:
        assert len(good) == len(clean)
        for g, c in zip(good, clean):
            np.testing.assert_array_equal(g, c)
        # counts add up: each touched frame gives at most one row; garbage at most one spurious row
        assert dec.frames == n - len(touched)
        assert dec.invalid <= len(touched) + between
        # so the time base is off by at most that much: clean frame i lands at row i, moved
        # earlier by touched frames that left no row, later by spurious rows from garbage
        at = np.flatnonzero([r.valid for r in rows])
        sent_at = np.array([i for i in range(n) if i not in touched])
        assert np.all(at >= sent_at - len(touched)) and np.all(at <= sent_at + between)
    # all frames after the last corruption are recovered
    last = max(touched) if touched else -1
    tail = [r for r in rows][-(n - last - 1):]
    assert all(r.valid for r in tail)
    np.testing.assert_array_equal(np.stack([r.data for r in tail]), sent[last + 1:])
    assert dec.skipped <= len(stream) - dec.frames * len(packets[0])


def test_v1_chunking_does_not_change_the_result():
    rng = np.random.default_rng(7)
    sent = psm_frames(rng, 120, (4, 4))
    stream, _, _ = corrupt([encode_v1(f) for f in sent], rng, 30, ("flip", "drop", "burst", "insert", "garbage"))
    whole = V1Decoder((4, 4))
    ref = whole.feed(stream) + whole.finish()
    for seed in range(3):
        dec = V1Decoder((4, 4))
        got = feed_chunks(dec, stream, np.random.default_rng(seed))
        assert [(e.valid, e.offset) for e in got] == [(e.valid, e.offset) for e in ref]
        assert dec.stats == whole.stats
    byte_by_byte = V1Decoder((4, 4))
    got = [e for b in range(len(stream)) for e in byte_by_byte.feed(stream[b:b + 1])] + byte_by_byte.finish()
    assert [(e.valid, e.offset) for e in got] == [(e.valid, e.offset) for e in ref]


def test_v1_garbage_bytes_counted():
    frame = encode_v1(np.full((2, 2), 7))
    garbage = bytes(range(1, 40))          # no 0xFF, no 0xA5 0x5A
    dec = V1Decoder((2, 2))
    events = dec.feed(garbage + frame + garbage[:5] + frame)
    assert [e.valid for e in events] == [True, True]
    assert dec.skipped == len(garbage) + 5


def test_v1_interleaved_replies_fuzzed():
    """A v1 stream with v2 replies between frames and random chunking: all frames, all replies."""
    rng = np.random.default_rng(8)
    sent = psm_frames(rng, 200, (16, 16))
    pieces, n_replies = [], 0
    for i, f in enumerate(sent):
        pieces.append(encode_v1(f))
        if rng.random() < 0.2:
            t = int(rng.integers(0, WRAP)) | 0xFFFF  # force 0xFF 0xFF inside the reply
            pieces.append(encode_reply(4, 0, "device=psm rows=16 cols=16", seq=i, t_us=t))
            n_replies += 1
    dec = V1Decoder((16, 16))
    events = feed_chunks(dec, b"".join(pieces), rng)
    frames = [e for e in events if isinstance(e, Frame)]
    assert all(e.valid for e in frames) and len(frames) == 200
    assert sum(isinstance(e, Reply) for e in events) == n_replies == dec.replies
    assert dec.invalid == 0 and dec.skipped == 0


def test_v1_buffer_stays_small():
    rng = np.random.default_rng(9)
    data = b"".join(encode_v1(f) for f in rng.integers(0, 4096, (2000, 16, 16)))
    dec = V1Decoder((16, 16))
    n = 0
    for i in range(0, len(data), 4096):
        n += len(dec.feed(data[i:i + 4096]))
        assert dec.pending < 516
    assert n == 2000


# --- v2 ----------------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", [11, 12, 13])
@pytest.mark.parametrize("shape", [(16, 16), (3, 5), (1, 1)])
def test_v2_fuzz_counts_add_up(seed, shape):
    rng = np.random.default_rng(seed)
    n = 300
    sent = psm_frames(rng, n, shape)
    seq0, t0, dt = WRAP - 150, WRAP - 1_000_000, 6061      # both counters wrap mid-run
    packets = [encode_v2(f, (seq0 + i) % WRAP, (t0 + dt * i) % WRAP) for i, f in enumerate(sent)]
    stream, touched, _ = corrupt(packets, rng, 60, ("flip", "drop", "burst", "insert", "garbage"))
    dec = V2Decoder()
    events = feed_chunks(dec, stream, rng)
    rows = [e for e in events if isinstance(e, Frame)]
    good = [r for r in rows if r.valid]
    clean = [i for i in range(n) if i not in touched]
    assert [r.seq for r in good] == [(seq0 + i) % WRAP for i in clean]
    assert [r.t_us for r in good] == [t0 + dt * i for i in clean]       # unwrapped, monotonic
    for r, i in zip(good, clean):
        np.testing.assert_array_equal(r.data, sent[i])
    assert dec.frames == len(clean)
    assert dec.frames + dec.invalid + dec.dropped == n                   # nothing unaccounted for
    assert sum(e.count for e in events if isinstance(e, Gap)) == dec.dropped
    assert dec.invalid <= len(touched)


def test_v2_chunking_does_not_change_the_result():
    rng = np.random.default_rng(14)
    sent = psm_frames(rng, 120, (4, 4))
    packets = [encode_v2(f, i, 1000 * i) for i, f in enumerate(sent)]
    stream, _, _ = corrupt(packets, rng, 30, ("flip", "drop", "burst", "insert", "garbage"))
    whole = V2Decoder()
    ref = whole.feed(stream) + whole.finish()
    key = lambda evs: [(type(e).__name__, getattr(e, "valid", None), getattr(e, "offset", None)) for e in evs]
    for seed in range(3):
        dec = V2Decoder()
        assert key(feed_chunks(dec, stream, np.random.default_rng(seed))) == key(ref)
        assert dec.stats == whole.stats


def test_v2_bogus_long_header_at_end_of_stream():
    """A plausible header claiming a long payload must not hide the complete frames behind it."""
    f = np.zeros((2, 2), dtype=np.uint16)
    bogus = encode_v2(np.zeros((64, 64), dtype=np.uint16), 0, 0)[:16]   # header only
    dec = V2Decoder()
    events = dec.feed(bogus + encode_v2(f, 1, 10) + encode_v2(f, 2, 20))
    assert events == []                                   # still waiting for the bogus payload
    events = dec.finish()
    assert [e.seq for e in events] == [1, 2]
    assert dec.skipped == 16


def test_v2_invalid_rows_at_their_position_and_dropped():
    f = np.ones((2, 2), dtype=np.uint16)
    packets = [bytearray(encode_v2(f, s, 1000 * s)) for s in range(8)]
    packets[2][18] ^= 0x01               # payload error -> invalid row
    packets[4][5] ^= 0x80                # seq byte error -> invalid row (CRC)
    packets[6][0] = 0x00                 # sync destroyed -> lost, seen as a gap
    dec = V2Decoder()
    events = dec.feed(b"".join(bytes(p) for p in packets))
    rows = [(type(e).__name__, getattr(e, "valid", None)) for e in events]
    assert rows == [("Frame", True), ("Frame", True), ("Frame", False), ("Frame", True), ("Frame", False),
                    ("Frame", True), ("Gap", None), ("Frame", True)]
    assert dec.dropped == 1 and dec.invalid == 2 and dec.frames == 5
    assert dec.skipped == len(packets[6])


# --- IMU v1 ------------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", [21, 22, 23])
def test_imu_v1_fuzz(seed):
    rng = np.random.default_rng(seed)
    n = 300
    sent = rng.uniform(-180, 180, (n, 5, 3)).astype(np.float32)
    sent[::7, 0, 0] = np.frombuffer(b"\xff\xff\x7f\x3f", dtype="<f4")[0]   # FF FF inside payloads
    packets = [encode_imu_v1(a) for a in sent]
    stream, touched, _ = corrupt(packets, rng, 40, ("flip", "drop", "burst", "insert", "garbage"))
    dec = ImuV1Decoder()
    events = feed_chunks(dec, stream, rng)
    rows = [e for e in events if isinstance(e, Frame)]
    good = [r.data for r in rows if r.valid]
    clean = [sent[i] for i in range(n) if i not in touched]
    # every clean sample is recovered, in order, unless a corrupted candidate passed the 12-bit
    # check by chance and swallowed it (at most one per such bogus row)
    index = {a.tobytes(): i for i, a in enumerate(sent)}
    matched = [index.get(g.tobytes()) for g in good]
    bogus = matched.count(None)
    found = {i for i in matched if i is not None}
    assert sum(i not in found for i in range(n) if i not in touched) <= bogus
    order = [i for i in matched if i is not None]
    assert order == sorted(order)
    # the v1 check (sum of words mod 4096) cannot see an error in bits 12-15 of a payload
    # word, which floats do not forbid: a corrupted sample can pass; at most one per corruption
    assert len(good) <= len(clean) + len(touched)
    for r in rows:
        assert r.data.shape == (5, 3) and r.data.dtype == np.float32
        if not r.valid:
            assert np.isnan(r.data).all()
