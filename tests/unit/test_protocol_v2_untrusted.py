"""A v2 header whose packet failed its CRC is not trusted.

Neither its shape (one bad packet of another shape must not reject a recording) nor its
length (overlapping fake headers must not become one invalid row each). Expectations come
from how the test streams are built.
"""

from __future__ import annotations

import numpy as np

from psmat.protocol import Frame, V2Decoder, decode_v2, encode_v2, v2_frame_size


def _bad_crc(packet: bytes) -> bytes:
    """``packet`` with its CRC inverted: the header stays plausible, the check fails."""
    return packet[:-2] + bytes(b ^ 0xFF for b in packet[-2:])


def _frames(n: int) -> list[bytes]:
    return [encode_v2(np.full((16, 16), 100 + i), i, 6061 * i) for i in range(n)]


def test_a_bad_packet_of_another_shape_does_not_reject_the_recording() -> None:
    good = _frames(10)
    stray = _bad_crc(encode_v2(np.full((4, 4), 7), 99, 0))     # plausible 4x4 header, bad CRC
    for where in (0, 5):                                          # before the first frame, mid-stream
        out = decode_v2(b"".join(good[:where]) + stray + b"".join(good[where:]))
        assert out["frames"].shape == (10, 16, 16)
        assert out["valid"].all()
        np.testing.assert_array_equal(out["seq"], np.arange(10))
        np.testing.assert_array_equal(out["frames"][:, 0, 0], 100 + np.arange(10))
        assert out["dropped"] == 0


def test_after_a_valid_frame_a_bad_packet_of_another_shape_is_garbage() -> None:
    good = _frames(3)
    stray = _bad_crc(encode_v2(np.full((4, 4), 7), 99, 0))
    assert b"\xa5\x5a" not in stray[1:]                           # its only sync is its first
    dec = V2Decoder()
    events = dec.feed(good[0] + stray + good[1] + good[2])
    assert [(e.valid, e.seq) for e in events] == [(True, 0), (True, 1), (True, 2)]
    assert dec.invalid == 0 and dec.skipped == len(stray)


def test_overlapping_fake_headers_cost_at_most_their_bytes() -> None:
    """256 KiB of back-to-back fake 64x64 headers (each claims 8210 bytes, has a bad CRC).

    A row owns the span its header claims, so candidates inside it are no rows: the first
    header at offset 0 is a row, the next row is the first header at or after 8210, i.e.
    at 8224 (headers every 16 bytes), and so on while a whole span fits:
    rows = (len - 8210) // 8224 + 1.
    """
    span = v2_frame_size((64, 64))
    assert span == 8210
    header = encode_v2(np.zeros((64, 64), np.uint16), 1, 2)[:16]
    data = header * (256 * 1024 // 16)
    rows = (len(data) - span) // 8224 + 1
    out = decode_v2(data)
    assert out["frames"].shape == (rows, 64, 64) and not out["valid"].any()
    assert out["frames"].nbytes <= len(data)
    dec = V2Decoder()
    dec.feed(data)
    dec.finish()
    assert dec.invalid == rows and dec.frames == 0


def test_one_corrupted_frame_with_a_header_inside_is_one_invalid_row() -> None:
    """A payload that holds a 16x16 header; the frame's CRC fails: one invalid row, not two."""
    inner = encode_v2(np.zeros((16, 16), np.uint16), 77, 0)[:16]
    cells = np.full((16, 16), 5, np.uint16)
    cells.flat[:8] = np.frombuffer(inner, "<u2")                  # the header's bytes, as counts
    packets = _frames(6)
    bad = bytearray(encode_v2(cells, 3, 3 * 6061))
    bad[-3] ^= 0x01                                               # last payload byte: CRC fails
    packets[3] = bytes(bad)
    dec = V2Decoder()
    events = dec.feed(b"".join(packets)) + dec.finish()
    rows = [e for e in events if isinstance(e, Frame)]
    assert [(r.valid, r.seq) for r in rows] == [(True, 0), (True, 1), (True, 2), (False, None), (True, 4),
                                                (True, 5)]
    assert dec.invalid == 1 and dec.dropped == 0
