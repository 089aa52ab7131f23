"""Decoding costs a bounded amount of work per input byte, whatever the input.

The rules are in docs/protocol.md ("Decoding cost") and the docstring of the decoders' module
(psmat/protocol/_decoder.py). Work is counted, never timed: ``decoder.work`` holds the
markers judged (``candidates``), the bytes run through the CRC-16 (``crc_bytes``) and the bytes
read by the v1 checks (``check_bytes``). Every bound below is derived by hand from the framing
(in the test's docstring or comments); the streams are built here from seeded generators, and
the expected rows are counted from how each stream was built, never from a decoder's output.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import pytest
from crc_reference import crc16_table
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from psmat.protocol import (DaqLineDecoder, DaqMalformed, DaqSample, Frame, Gap, ImuV1Decoder, Reply, V1Decoder,
                            V2Decoder, encode_daq_line, encode_imu_v1, encode_reply, encode_v1, encode_v2,
                            v2_frame_size)
from psmat.protocol import crc16_shift
from psmat.protocol import SpanCrc

N = 1 << 17                      # bytes in each adversarial stream (128 KiB)
CHUNK = 4096                     # what a serial port might deliver per read
MAX_PACKET = 16 + 8192 + 2       # the largest v2 packet (docs/protocol.md)
PSM = (16, 16)
V1_SIZE = 2 + 2 * 16 * 16 + 2    # 516
IMU_SIZE = 2 + 60 + 2            # 64
STRIDE = 16                      # SpanCrc's register spacing (docs/protocol.md)


# --- streams -----------------------------------------------------------------------------------

def _repeat(unit: bytes, n: int = N) -> bytes:
    return (unit * (n // len(unit) + 1))[:n]


def _fake_psm_header() -> bytes:
    """A plausible 64x64 PSM header: claims n = 8192, a packet of 8210 bytes."""
    return encode_v2(np.zeros((64, 64), np.uint16), 1, 2)[:16]


def _fake_imu_header() -> bytes:
    """A plausible 64x32 IMU header: claims n = 4*64*32 = 8192."""
    return encode_v2(np.zeros((64, 32), np.float32), 1, 2, kind="imu")[:16]


def _fake_reply_header() -> bytes:
    """A plausible reply header (rows = cols = 0) claiming n = 8192."""
    return encode_reply(4, 0, "x" * 8190)[:16]


def _flip_every(stream: bytes, every: int) -> tuple[bytes, list[int]]:
    """Bit 0 of every ``every``-th byte flipped; returns the stream and the flipped offsets."""
    out = bytearray(stream)
    at = list(range(every - 1, len(out), every))
    for i in at:
        out[i] ^= 0x01
    return bytes(out), at


def _psm_counts(rng: np.random.Generator, n: int, shape: tuple[int, int] = PSM) -> np.ndarray:
    return rng.integers(0, 4096, (n, *shape))


def _imu_angles(rng: np.random.Generator, n: int) -> np.ndarray:
    """Half-degree angles: exact in float32, their low two bytes 00 00 and no byte 0xFF at all
    (|a| < 256 keeps the exponent byte <= 0x43 | sign), so ``FF FF`` only marks frame starts."""
    return (rng.integers(-359, 360, (n, 5, 3)) / 2).astype(np.float32)


def _v2_packets(rng: np.random.Generator, n: int, shape: tuple[int, int] = PSM) -> list[bytes]:
    return [encode_v2(f, i, 10_000 * i) for i, f in enumerate(_psm_counts(rng, n, shape))]


def _adversarial() -> dict[str, bytes]:
    rng = np.random.default_rng(2024)
    fake = _fake_psm_header()
    return {
        "random": rng.integers(0, 256, N, dtype=np.uint8).tobytes(),
        # the attack: a header claiming 8 KiB every 18 bytes
        "v2_headers_every_18": _repeat(fake + b"\x00\x00"),
        "v2_headers_back_to_back": _repeat(fake),
        "v2_imu_headers_back_to_back": _repeat(_fake_imu_header()),
        "v2_reply_headers_every_18": _repeat(_fake_reply_header() + b"\x00\x00"),
        "ff_ff_00_00": _repeat(b"\xff\xff\x00\x00"),
        "all_ff": b"\xff" * N,
        "all_00": bytes(N),
        # the v1 PSM pre-check's worst case: two candidates per frame pass it (FF FF FF then 513 zeros)
        "ff_run_then_zeros": _repeat(b"\xff\xff\xff" + bytes(V1_SIZE - 3)),
        # the IMU check's worst case: a long 0xFF run whose last 62 candidates see a check byte 0x00
        "imu_ff_run_then_zeros": _repeat(b"\xff" * IMU_SIZE + bytes(IMU_SIZE - 2)),
        "v1_every_1031st_flipped": _flip_every(b"".join(encode_v1(f) for f in _psm_counts(rng, N // V1_SIZE)),
                                               1031)[0],
        "v2_every_1031st_flipped": _flip_every(b"".join(_v2_packets(rng, N // 530)), 1031)[0],
        "imu_every_97th_flipped": _flip_every(b"".join(encode_imu_v1(a) for a in _imu_angles(rng, N // 64)),
                                              97)[0],
        "v2_max_frames_every_20011th_flipped": _flip_every(b"".join(_v2_packets(rng, 16, (64, 64))), 20011)[0],
        "v2_fake_max_headers_before_frames": b"".join(fake + _fake_imu_header() + p for p in _v2_packets(rng, 200)),
    }


STREAMS = _adversarial()
DECODERS: dict[str, Callable[[], V1Decoder | ImuV1Decoder | V2Decoder]] = {
    "v1": lambda: V1Decoder(PSM), "imu": ImuV1Decoder, "v2": V2Decoder,
}


def _decode(dec, data: bytes, chunk: int = CHUNK) -> tuple[list, int]:
    """Events of ``data`` fed in ``chunk``-byte pieces, and the most bytes held after a feed."""
    events, held = [], 0
    for i in range(0, len(data), chunk):
        events += dec.feed(data[i:i + chunk])
        held = max(held, dec.pending)
    return events + dec.finish(), held


def _key(events: list) -> list[tuple]:
    """Everything an event says, comparable."""
    out = []
    for e in events:
        if isinstance(e, Frame):
            out.append(("F", e.kind, e.valid, e.seq, e.t_us, e.offset, e.data.shape, e.data.tobytes()))
        elif isinstance(e, Reply):
            out.append(("R", e.opcode, e.status, e.text, e.seq, e.t_us, e.offset))
        else:
            assert isinstance(e, Gap)
            out.append(("G", e.count, e.seq))
    return out


# --- work per byte -----------------------------------------------------------------------------

@pytest.mark.parametrize("decoder", sorted(DECODERS))
@pytest.mark.parametrize("name", sorted(STREAMS))
def test_work_per_byte_is_bounded(name: str, decoder: str) -> None:
    """Bounds that hold whatever the bytes are.

    * candidates: each starts at its own byte, so at most one per byte;
    * CRC: a span that does not overlap the last one read directly is read once; the prefix
      chain reads each byte once more at most; each overlapping candidate reads fewer than
      ``STRIDE`` bytes at either end: ``crc_bytes <= 2 n + 2 STRIDE candidates``. In these
      streams plausible v2 headers are at least 16 bytes apart (a header is 16 bytes), so at
      most ``n / 16`` candidates and ``crc_bytes <= 4 n`` - where a plain decoder reads the
      8208 bytes each fake header claims, 456 per byte of ``v2_headers_every_18``;
    * v1 PSM checks: the pre-check scans a candidate's span up to its first ``FF FF``; two
      candidates that pass it and are closer than a frame are the two last positions of an
      ``FF`` run, so the scans and the sums each read a byte about twice: ``<= 4 n`` plus a
      frame or two at the ends;
    * IMU checks (62 bytes each): a checked candidate ``k`` needs ``0xFF`` at ``k`` and a check
      byte ``<= 0x0F`` at ``k + 63``, both its own, so ``check_bytes <= 62 min(#0xFF, #<=0x0F)``;
    * memory: what is held after a feed is less than one packet (an incomplete candidate).
    """
    data = STREAMS[name]
    n = len(data)
    dec = DECODERS[decoder]()
    _, held = _decode(dec, data)
    w = dec.work
    assert dec.bytes_in == n
    assert w["candidates"] <= n
    assert w["crc_bytes"] <= 2 * n + 2 * STRIDE * w["candidates"]
    assert w["crc_bytes"] <= 4 * n
    if decoder == "v1":
        assert w["check_bytes"] <= 4 * n + 4 * V1_SIZE
    elif decoder == "imu":
        arr = np.frombuffer(data, np.uint8)
        assert w["check_bytes"] <= (IMU_SIZE - 2) * min(int((arr == 0xFF).sum()), int((arr <= 0x0F).sum()))
    else:
        assert w["check_bytes"] == 0                  # v2 has no v1 checks
    assert held < MAX_PACKET
    assert dec.pending == 0                           # finish() judged everything


@pytest.mark.parametrize("decoder", sorted(DECODERS))
@pytest.mark.parametrize("name", sorted(STREAMS))
def test_invalid_rows_never_exceed_the_bytes(name: str, decoder: str) -> None:
    """Invalid rows do not overlap and each stands for a whole frame's bytes, all inside the
    stream: v1 at most ``n // 516``, IMU ``n // 64``; v2 rows of any shapes hold at most ``n``
    bytes together (``16 + n + 2`` each, from the shape the row reports)."""
    data = STREAMS[name]
    dec = DECODERS[decoder]()
    events, _ = _decode(dec, data)
    bad = [e for e in events if isinstance(e, Frame) and not e.valid]
    assert len(bad) == dec.invalid
    if decoder == "v1":
        assert dec.invalid <= len(data) // V1_SIZE
    elif decoder == "imu":
        assert dec.invalid <= len(data) // IMU_SIZE
    else:
        assert sum(v2_frame_size(e.data.shape, e.kind) for e in bad) <= len(data)
    spans = sorted((e.offset, e.offset + (V1_SIZE if decoder == "v1" else IMU_SIZE if decoder == "imu"
                                          else v2_frame_size(e.data.shape, e.kind))) for e in bad)
    assert all(a_end <= b_start for (_, a_end), (b_start, _) in zip(spans, spans[1:]))
    assert all(end <= len(data) for _, end in spans)


def test_ff_ff_00_00_is_one_invalid_row_per_frame_of_bytes() -> None:
    """``FF FF 00 00`` repeated (256 KiB). Every 4 bytes a marker, every candidate fails (cells
    0xFFFF). The row at 0 spans 516 bytes; the candidates at 4, 8, ..., 512 start inside it
    and are no rows; 516 is a multiple of 4, so the next row starts at 516, and so on: one row
    per 516 bytes, ``262144 // 516 = 508`` (it was 65 407, one per 4 bytes). The IMU frame
    (64 bytes) gives ``262144 / 64 = 4096``; v2 sees no sync, all garbage."""
    data = b"\xff\xff\x00\x00" * (1 << 16)
    v1 = V1Decoder(PSM)
    events, _ = _decode(v1, data)
    assert [e.offset for e in events] == [V1_SIZE * i for i in range(508)]
    assert not any(e.valid for e in events)
    assert v1.invalid == 508 and v1.frames == 0 and v1.skipped == len(data) - 508 * V1_SIZE
    # every span holds the next pair 4 bytes on: each candidate's pre-check reads those 4 bytes
    # and nothing is summed (a plain check would read 512 bytes per candidate)
    assert v1.check_bytes <= len(data)
    imu = ImuV1Decoder()
    events, _ = _decode(imu, data)
    assert [e.offset for e in events] == [IMU_SIZE * i for i in range(4096)]
    assert imu.invalid == 4096 and imu.skipped == 0
    v2 = V2Decoder()
    assert _decode(v2, data)[0] == [] and v2.skipped == len(data) and v2.work["candidates"] == 0


@pytest.mark.parametrize("fill", [0x00, 0xFF])
def test_uniform_streams_are_garbage_without_checks(fill: int) -> None:
    """All-0x00 holds no marker; all-0xFF holds one at every byte, but each candidate's check
    word would be 0xFFFF > 4095 (and a v1 PSM span holds ``FF FF``), so nothing is summed and
    nothing is a row: a run of 0xFF is false starts, skipped in steps, not byte by byte."""
    data = bytes([fill]) * N
    for make in DECODERS.values():
        dec = make()
        events, held = _decode(dec, data)
        assert events == [] and dec.skipped == N and dec.invalid == 0
        assert dec.work["check_bytes"] == 0 and dec.work["crc_bytes"] == 0
        assert dec.work["candidates"] <= N // 16
        assert held < IMU_SIZE + 2 if fill == 0xFF else held <= 1


@pytest.mark.parametrize("kind", ["v1", "imu", "v2"])
def test_flipped_streams_lose_only_the_touched_frames(kind: str) -> None:
    """A valid stream with bit 0 of every k-th byte flipped (k longer than a frame: at most one
    flip per frame). A single flipped bit always fails the v1 check (it moves the sum by 1 or
    256 mod 4096, or lifts a cell above 4095) and the CRC; every other frame is decoded, in
    order, with its data. Rows for the touched frames: at most one each."""
    rng = np.random.default_rng(7)
    if kind == "v1":
        sent = _psm_counts(rng, 600)
        packets = [encode_v1(f) for f in sent]
        every, dec = 1031, V1Decoder(PSM)
    elif kind == "imu":
        sent = _imu_angles(rng, 3000)
        packets = [encode_imu_v1(a) for a in sent]
        every, dec = 97, ImuV1Decoder()
    else:
        sent = _psm_counts(rng, 600)
        packets = [encode_v2(f, i, 10_000 * i) for i, f in enumerate(sent)]
        every, dec = 1031, V2Decoder()
    stream, flipped = _flip_every(b"".join(packets), every)
    starts = np.cumsum([0] + [len(p) for p in packets])
    touched = {int(np.searchsorted(starts, i, side="right")) - 1 for i in flipped}
    events, held = _decode(dec, stream)
    good = [e for e in events if isinstance(e, Frame) and e.valid]
    clean = [i for i in range(len(sent)) if i not in touched]
    assert len(good) == len(clean) and dec.frames == len(clean)
    for e, i in zip(good, clean):
        np.testing.assert_array_equal(e.data, sent[i])
        assert e.offset == starts[i]
    assert dec.invalid <= len(touched)
    if kind == "v2":
        assert [e.seq for e in good] == clean
        assert dec.frames + dec.invalid + dec.dropped == len(sent)
    w = dec.work
    assert w["crc_bytes"] <= 2 * len(stream) and w["check_bytes"] <= 4 * len(stream)
    assert held < MAX_PACKET


def test_fake_maximal_headers_hide_no_frame() -> None:
    """Before every valid 16x16 v2 frame, a 64x64 PSM header and a 64x32 IMU header, each
    claiming 8210 bytes, both failing their CRC. Every frame is decoded (the fake spans are
    waited for, then their CRCs fail); the fakes cost O(1) CRC bytes each beyond the stream's
    two passes. Once a 16x16 PSM frame is known a 64x64 PSM fake is no row; an IMU fake is a
    row only past the reported spans, so the rows hold at most the stream's bytes."""
    rng = np.random.default_rng(11)
    sent = _psm_counts(rng, 300)
    stream = b"".join(_fake_psm_header() + _fake_imu_header() + encode_v2(f, i, 100 * i)
                      for i, f in enumerate(sent))
    dec = V2Decoder()
    events, held = _decode(dec, stream)
    good = [e for e in events if isinstance(e, Frame) and e.valid]
    assert [e.seq for e in good] == list(range(300)) and dec.dropped == 0
    for e, f in zip(good, sent):
        np.testing.assert_array_equal(e.data, f)
    bad = [e for e in events if isinstance(e, Frame) and not e.valid]
    assert dec.invalid * 8210 <= len(stream)
    assert all(e.data.shape in ((64, 64), (64, 32)) for e in bad)
    assert dec.work["crc_bytes"] <= 2 * len(stream) + 2 * STRIDE * dec.work["candidates"]
    assert held < MAX_PACKET


# --- chunking does not change the events -------------------------------------------------------

_RNG = np.random.default_rng(99)
_PIECES = {
    "v1": encode_v1(_psm_counts(_RNG, 1)[0]),
    "v2": encode_v2(_psm_counts(_RNG, 1)[0], 5, 500),
    "v2_small": encode_v2(np.arange(6).reshape(2, 3), 6, 600),
    "imu": encode_imu_v1(_imu_angles(_RNG, 1)[0]),
    "reply": encode_reply(4, 0, "device=psm rows=16 cols=16"),
    "fake_psm": _fake_psm_header(),
    "fake_imu": _fake_imu_header(),
    "fake_reply": _fake_reply_header(),
    "ff_run": b"\xff" * 70,
    "ff_ff_00_00": b"\xff\xff\x00\x00" * 40,
    "zeros": bytes(50),
    "noise": _RNG.integers(0, 256, 300, dtype=np.uint8).tobytes(),
}


@st.composite
def _stream_and_cuts(draw) -> tuple[bytes, list[int], int]:
    names = draw(st.lists(st.sampled_from(sorted(_PIECES)), min_size=1, max_size=25))
    data = bytearray(b"".join(_PIECES[k] for k in names))
    flips = draw(st.lists(st.integers(0, len(data) - 1), max_size=6))
    for i in flips:
        data[i] ^= 0x01
    cuts = sorted(set(draw(st.lists(st.integers(0, len(data)), max_size=40))))
    return bytes(data), cuts, draw(st.sampled_from(sorted(DECODERS)))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_stream_and_cuts())
def test_chunking_does_not_change_the_events(case: tuple[bytes, list[int], str]) -> None:
    """Arbitrary pieces (valid packets, fake headers, 0xFF runs, noise, flipped bits) split at
    arbitrary points decode to the same events and counters as the whole stream, and what a
    decoder holds stays below one packet."""
    data, cuts, decoder = case
    whole = DECODERS[decoder]()
    ref = whole.feed(data) + whole.finish()
    dec = DECODERS[decoder]()
    got = []
    for a, b in zip([0] + cuts, cuts + [len(data)]):
        got += dec.feed(data[a:b])
        assert dec.pending < MAX_PACKET
    got += dec.finish()
    assert _key(got) == _key(ref)
    assert dec.stats == whole.stats


# --- the CRC of spans --------------------------------------------------------------------------

def test_crc16_shift_is_zero_bytes_through_the_register() -> None:
    rng = np.random.default_rng(3)
    for n in (0, 1, 2, 15, 16, 17, 530, 8208):
        for reg in (0, 1, 0xFFFF, int(rng.integers(0, 1 << 16))):
            assert crc16_shift(reg, n) == crc16_table(bytes(n), reg)
    with pytest.raises(ValueError, match="reg"):
        crc16_shift(1 << 16, 1)
    with pytest.raises(ValueError, match="n must"):
        crc16_shift(0, -1)


def test_span_crc_matches_the_reference_on_overlapping_spans() -> None:
    """Spans of a sliding buffer, starts non-decreasing, many overlapping (as fake headers make
    them), the buffer's head dropped as a decoder does: each CRC equals the table-driven
    reference over the span's bytes, and the bytes read stay within ``2 n + 2 STRIDE`` per span."""
    rng = np.random.default_rng(5)
    stream = rng.integers(0, 256, 40_000, dtype=np.uint8).tobytes()
    span, base, buf, fed = SpanCrc(), 0, bytearray(), 0
    a, queries = 0, 0
    while True:
        a += int(rng.integers(0, 40))
        b = a + int(rng.integers(0, 2000))
        if b > len(stream):
            break
        if fed < b:                                    # the port delivers up to the span's end
            buf += stream[fed:b]
            fed = b
        assert span.crc(buf, base, a, b) == crc16_table(stream[a:b])
        queries += 1
        cut = span.keep_from(a) - base                 # the decoder moves on to ``a``
        assert 0 <= a - (base + cut) < STRIDE          # at most a chain register's worth kept
        if cut > 0:
            del buf[:cut]
            base += cut
    assert queries > 500
    assert span.bytes <= 2 * fed + 2 * STRIDE * queries


# --- the material DAQ's lines ------------------------------------------------------------------

LINE = encode_daq_line(np.arange(10) * 100)


@pytest.mark.parametrize("chunk", [1 << 20, 4096, 7])
def test_daq_overlong_line_is_capped_and_counted_as_garbage(chunk: int) -> None:
    """A 1 MiB line without a newline: one malformed event as soon as it passes max_line, its
    bytes (with its ``\\r\\n``) counted as skipped, never held beyond max_line, and the next
    line is read normally."""
    junk = b"7," * (1 << 19)
    data = LINE + junk + b"\r\n" + LINE
    dec = DaqLineDecoder()
    events, held = [], 0
    for i in range(0, len(data), chunk):
        events += dec.feed(data[i:i + chunk])
        held = max(held, dec.pending)
    events += dec.finish()
    assert [type(e) for e in events] == [DaqSample, DaqMalformed, DaqSample]
    assert events[1].raw == junk[:80] and "longer than 256" in events[1].reason
    assert [e.line for e in events] == [0, 1, 2]
    assert dec.skipped == len(junk) + 2
    assert held <= dec.max_line
    assert dec.stats == {"bytes_in": len(data), "lines": 3, "samples": 2, "malformed": 1, "blank": 0,
                         "skipped": len(junk) + 2}


@settings(max_examples=80, deadline=None)
@given(st.lists(st.sampled_from([LINE, b"x" * 300 + b"\n", b"1,2,3\r\n", b"\r\n", b"9" * 257, b"5,5"]),
                max_size=12),
       st.lists(st.integers(0, 5000), max_size=20))
def test_daq_chunking_does_not_change_the_lines(pieces: list[bytes], cuts: list[int]) -> None:
    data = b"".join(pieces)
    whole = DaqLineDecoder()
    ref = whole.feed(data) + whole.finish()
    dec = DaqLineDecoder()
    got = []
    points = sorted({min(c, len(data)) for c in cuts})
    for a, b in zip([0] + points, points + [len(data)]):
        got += dec.feed(data[a:b])
        assert dec.pending <= dec.max_line
    got += dec.finish()

    def key(evs: list) -> list[tuple]:
        return [(type(e).__name__, e.line, getattr(e, "raw", None),
                 e.counts.tolist() if isinstance(e, DaqSample) else None) for e in evs]

    assert key(got) == key(ref)
    assert dec.stats == whole.stats
