"""Protocol v1 (thesis framing) byte layouts, round trips and errors (docs/protocol.md)."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from psmat import protocol
from psmat.protocol import (V1Decoder, decode_imu_v1, decode_v1, encode_imu_v1, encode_reply, encode_v1,
                            encode_v1_many, v1_frame_size)

FRAME_2X3 = np.array([[0x0FFF, 0x0123, 0], [0x0A5A, 1, 0x0800]])
# Hand-written: INIT INIT, cells row-major little-endian, check = 9085 mod 4096 = 893 = 0x037D.
BYTES_2X3 = bytes([0xFF, 0xFF,
                   0xFF, 0x0F, 0x23, 0x01, 0x00, 0x00,
                   0x5A, 0x0A, 0x01, 0x00, 0x00, 0x08,
                   0x7D, 0x03])


def test_layout_2x3():
    assert encode_v1(FRAME_2X3) == BYTES_2X3
    assert encode_v1(FRAME_2X3.astype(np.uint16)) == BYTES_2X3
    assert encode_v1(FRAME_2X3.tolist()) == BYTES_2X3
    assert v1_frame_size((2, 3)) == len(BYTES_2X3) == 16
    assert v1_frame_size((16, 16)) == 516


def test_layout_small_values_and_check_wrap():
    assert encode_v1([[1, 2, 3], [4, 5, 6]]) == bytes.fromhex("ffff 0100 0200 0300 0400 0500 0600 1500")
    # 2 x 4095 = 8190 -> 8190 mod 4096 = 4094 = 0x0FFE
    assert encode_v1([[4095, 4095]]) == bytes.fromhex("ffff ff0f ff0f fe0f")
    assert encode_v1([[0]]) == bytes.fromhex("ffff 0000 0000")


def test_public_contract_names():
    assert protocol.encode_v1 is encode_v1 and protocol.decode_v1 is decode_v1
    assert "encode_v1" in protocol.__all__ and "decode_v1" in protocol.__all__
    for name in protocol.__all__:
        assert hasattr(protocol, name)


def test_decode_layout_2x3():
    frames, valid = decode_v1(BYTES_2X3 * 2, (2, 3))
    assert frames.dtype == np.uint16 and frames.shape == (2, 2, 3)
    assert valid.dtype == np.bool_ and valid.tolist() == [True, True]
    assert (frames == FRAME_2X3).all()


@pytest.mark.parametrize("shape", [(1, 1), (16, 16), (3, 5), (64, 64)])
def test_round_trip(shape, rng):
    n = 40 if shape != (64, 64) else 6
    sent = rng.integers(0, 4096, (n, *shape))
    sent[0] = 4095  # all-0x0FFF cells: lo bytes 0xFF next to the marker
    sent[1] = 0
    data = b"".join(encode_v1(f) for f in sent)
    assert data == encode_v1_many(sent)
    assert len(data) == n * (4 + 2 * shape[0] * shape[1])
    frames, valid = decode_v1(data, shape)
    assert valid.all() and frames.shape == (n, *shape)
    np.testing.assert_array_equal(frames, sent)
    # the same through the incremental decoder, one byte at a time for small frames
    dec = V1Decoder(shape)
    step = 1 if shape[0] * shape[1] < 100 else 997
    events = []
    for i in range(0, len(data), step):
        events += dec.feed(data[i:i + step])
    assert [e.valid for e in events] == [True] * n
    np.testing.assert_array_equal(np.stack([e.data for e in events]), sent)
    assert dec.stats == {"bytes_in": len(data), "frames": n, "invalid": 0, "skipped": 0, "dropped": 0,
                         "replies": 0, "restarts": 0}


def test_bad_check_kept_as_invalid_row():
    good = encode_v1(FRAME_2X3)
    bad = bytearray(good)
    bad[-2] ^= 0x01                              # check off by one
    frames, valid = decode_v1(good + bytes(bad) + good, (2, 3))
    assert valid.tolist() == [True, False, True]
    assert (frames[1] == 0).all() and (frames[0] == FRAME_2X3).all() and (frames[2] == FRAME_2X3).all()


def test_cell_above_12_bits_is_invalid():
    bad = bytearray(encode_v1([[1, 2, 3], [4, 5, 6]]))
    bad[3] = 0x10                                # cell 0 = 0x1001 > 4095; fix the check to match the sum
    total = 0x1001 + 2 + 3 + 4 + 5 + 6
    bad[-2:] = (total & 0xFFF).to_bytes(2, "little")
    frames, valid = decode_v1(bytes(bad), (2, 3))
    assert valid.tolist() == [False]


def test_leading_garbage_and_partial_frames():
    good = encode_v1(FRAME_2X3)
    data = b"\x00\x12\xff" + good[5:] + good + b"\xff" + good + good[:7]
    dec = V1Decoder((2, 3))
    events = dec.feed(data) + dec.finish()
    frames = [e for e in events]
    assert [e.valid for e in frames] == [True, True]
    assert frames[0].offset == 3 + len(good) - 5
    # garbage: 3 + (16-5) leading bytes, the lone 0xFF, and the 7-byte tail at the end of stream
    assert dec.skipped == 3 + 11 + 1 + 7
    assert dec.pending == 0


def test_false_start_ff_before_marker():
    good = encode_v1([[4095, 1, 2], [3, 4, 5]])   # cell 0 lo byte is 0xFF: FF FF FF 0F ...
    frames, valid = decode_v1(b"\xff" + good + b"\xff\xff" + good, (2, 3))
    assert valid.tolist() == [True, True]


def test_v1_reader_skips_v2_replies():
    good = encode_v1(FRAME_2X3)
    r1 = encode_reply(4, 0, "device=psm rows=2 cols=3", seq=0xFFFF, t_us=0xFFFF_FF00)  # FF FF inside
    r2 = encode_reply(3, 1, b"", seq=1, t_us=2)
    assert b"\xff\xff" in r1
    dec = V1Decoder((2, 3))
    data = good + r1 + good + good + r2 + good
    events = []
    for i in range(0, len(data), 5):
        events += dec.feed(data[i:i + 5])
    kinds = [type(e).__name__ for e in events]
    assert kinds == ["Frame", "Reply", "Frame", "Frame", "Reply", "Frame"]
    assert all(e.valid for e in events if type(e).__name__ == "Frame")
    assert events[1].opcode == 4 and events[1].status == 0 and events[1].text == "device=psm rows=2 cols=3"
    assert events[4].opcode == 3 and events[4].status == protocol.Status.BAD_ARGUMENT
    assert dec.replies == 2 and dec.invalid == 0 and dec.skipped == 0
    frames, valid = decode_v1(data, (2, 3))
    assert valid.tolist() == [True] * 4


def test_empty_stream():
    frames, valid = decode_v1(b"", (4, 4))
    assert frames.shape == (0, 4, 4) and frames.dtype == np.uint16 and valid.shape == (0,)


# --- IMU v1 -------------------------------------------------------------------------------

def test_imu_layout():
    angles = np.zeros((5, 3))
    angles[0] = (1.0, -2.5, 0.0)
    angles[4, 2] = 90.0
    payload = struct.pack("<15f", *angles.ravel())
    assert payload[:12] == bytes.fromhex("0000803f 000020c0 00000000")
    # words: 0x0000 0x3F80 0x0000 0xC020 ... and 90.0f = 0x42B40000 -> 0x0000 0x42B4
    check = (0x3F80 + 0xC020 + 0x42B4) % 4096
    assert encode_imu_v1(angles) == b"\xff\xff" + payload + check.to_bytes(2, "little")
    assert len(encode_imu_v1(angles)) == 64


def test_imu_round_trip(rng):
    sent = rng.uniform(-180, 180, (50, 5, 3)).astype(np.float32)
    data = b"".join(encode_imu_v1(a) for a in sent)
    angles, valid = decode_imu_v1(data)
    assert angles.dtype == np.float32 and valid.all()
    np.testing.assert_array_equal(angles, sent)


def test_imu_bad_check_nan_row(rng):
    sent = rng.uniform(-180, 180, (3, 5, 3)).astype(np.float32)
    chunks = [bytearray(encode_imu_v1(a)) for a in sent]
    chunks[1][10] ^= 0x04
    angles, valid = decode_imu_v1(b"".join(bytes(c) for c in chunks))
    assert valid.tolist() == [True, False, True]
    assert np.isnan(angles[1]).all()


# --- errors ---------------------------------------------------------------------------------

def test_encode_errors():
    with pytest.raises(TypeError, match="integer"):
        encode_v1(np.zeros((2, 2)))
    with pytest.raises(TypeError, match="integer"):
        encode_v1(np.zeros((2, 2), dtype=bool))
    with pytest.raises(ValueError, match=r"\[0, 4095\].*\[0, 4096\]"):
        encode_v1([[0, 4096]])
    with pytest.raises(ValueError, match=r"\[-1, 3\]"):
        encode_v1([[-1, 3]])
    with pytest.raises(ValueError, match="shape"):
        encode_v1([1, 2, 3])
    with pytest.raises(ValueError, match="shape"):
        encode_v1(np.zeros((2, 2, 2), dtype=np.int64))
    with pytest.raises(ValueError, match="shape"):
        encode_v1(np.zeros((0, 3), dtype=np.int64))
    with pytest.raises(ValueError, match="shape"):
        encode_v1_many(np.zeros((2, 2), dtype=np.int64))
    with pytest.raises(ValueError, match="4095"):
        encode_v1_many(np.full((2, 2, 2), 5000))
    assert encode_v1_many(np.zeros((0, 2, 2), dtype=np.int64)) == b""


def test_imu_encode_errors():
    with pytest.raises(ValueError, match=r"\(5, 3\)"):
        encode_imu_v1(np.zeros((3, 5)))
    with pytest.raises(ValueError, match="finite"):
        encode_imu_v1(np.full((5, 3), np.nan))
    with pytest.raises(ValueError, match="float32"):
        encode_imu_v1(np.full((5, 3), 1e300))
    with pytest.raises(TypeError, match="real"):
        encode_imu_v1(np.zeros((5, 3), dtype=complex))


def test_decode_errors():
    with pytest.raises(ValueError, match="positive"):
        decode_v1(b"", (0, 3))
    with pytest.raises(ValueError, match="pair"):
        decode_v1(b"", 16)
    with pytest.raises(TypeError, match="integers"):
        decode_v1(b"", (2.0, 3))
    with pytest.raises(TypeError, match="bytes-like"):
        decode_v1("ffff", (1, 1))
    with pytest.raises(TypeError, match="bytes-like"):
        V1Decoder((1, 1)).feed([0xFF, 0xFF])
