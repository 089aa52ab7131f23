"""Protocol v2 packets, replies and commands: byte layouts written out from docs/protocol.md."""

from __future__ import annotations

import numpy as np
import pytest
from crc_reference import crc_bitwise

from psmat.protocol import (CAL_RESUME, Gap, Opcode, Reply, Status, V2Decoder, cal_hold_arg, decode_command,
                            decode_v2, encode_command, encode_reply, encode_v2, format_identify, parse_identify,
                            v2_frame_size)




def with_crc(packet_without_crc: bytes, start: int = 2) -> bytes:
    c = crc_bitwise(packet_without_crc[start:])
    return packet_without_crc + bytes([c & 0xFF, c >> 8])


def test_psm_layout_2x3():
    frame = [[0x0FFF, 0x0123, 0], [0x0A5A, 1, 0x0800]]
    expected = with_crc(bytes([
        0xA5, 0x5A,                 # sync
        0x02,                       # version
        0x01,                       # type PSM
        0x04, 0x03, 0x02, 0x01,     # seq 0x01020304
        0xD0, 0xC0, 0xB0, 0xA0,     # t_us 0xA0B0C0D0
        0x02, 0x03,                 # rows, cols
        0x0C, 0x00,                 # n = 12
        0xFF, 0x0F, 0x23, 0x01, 0x00, 0x00, 0x5A, 0x0A, 0x01, 0x00, 0x00, 0x08,
    ]))
    assert encode_v2(frame, 0x01020304, 0xA0B0C0D0) == expected
    assert len(expected) == v2_frame_size((2, 3)) == 16 + 12 + 2
    assert v2_frame_size((16, 16)) == 530
    assert v2_frame_size((5, 3), "imu") == 16 + 60 + 2


def test_imu_layout():
    angles = np.zeros((5, 3), dtype=np.float32)
    angles[0, 0] = 1.0
    angles[4, 2] = -2.5
    payload = bytes.fromhex("0000803f") + bytes(52) + bytes.fromhex("000020c0")
    expected = with_crc(bytes([0xA5, 0x5A, 0x02, 0x02, 7, 0, 0, 0, 0, 1, 0, 0, 5, 3, 60, 0]) + payload)
    assert encode_v2(angles, 7, 256, kind="imu") == expected


def test_reply_layout():
    expected = with_crc(bytes([0xA5, 0x5A, 0x02, 0x11, 5, 0, 0, 0, 7, 0, 0, 0, 0, 0, 12, 0, 0x04, 0x00])
                        + b"device=psm")
    assert encode_reply(Opcode.IDENTIFY, Status.OK, "device=psm", seq=5, t_us=7) == expected
    assert encode_reply(4, 0, b"device=psm", seq=5, t_us=7) == expected


def test_command_layout():
    assert encode_command(Opcode.SET_RATE, 165) == with_crc(bytes([0xA5, 0x5A, 0x02, 0x10, 0x03, 0xA5, 0, 0, 0]))
    assert encode_command(Opcode.START) == with_crc(bytes([0xA5, 0x5A, 0x02, 0x10, 0x01, 0, 0, 0, 0]))
    assert encode_command(Opcode.CAL_HOLD, CAL_RESUME) == with_crc(
        bytes([0xA5, 0x5A, 0x02, 0x10, 0x06, 0xFF, 0xFF, 0xFF, 0xFF]))
    assert encode_command(Opcode.CAL_HOLD, cal_hold_arg(3, 12)) == with_crc(
        bytes([0xA5, 0x5A, 0x02, 0x10, 0x06, 0x0C, 0x03, 0x00, 0x00]))
    assert len(encode_command(0x7E, 1)) == 11


def test_opcode_values():
    assert [int(o) for o in Opcode] == [1, 2, 3, 4, 5, 6]
    assert [o.name for o in Opcode] == ["START", "STOP", "SET_RATE", "IDENTIFY", "SET_PROTOCOL", "CAL_HOLD"]
    assert (Status.OK, Status.BAD_ARGUMENT, Status.UNKNOWN_OPCODE) == (0, 1, 2)


def test_decode_command():
    for op, arg in [(Opcode.SET_RATE, 1000), (Opcode.SET_PROTOCOL, 1), (Opcode.CAL_HOLD, CAL_RESUME)]:
        got = decode_command(encode_command(op, arg))
        assert got == (op, arg) and isinstance(got[0], Opcode)
    assert decode_command(encode_command(0x7E, 9)) == (0x7E, 9)
    bad = bytearray(encode_command(Opcode.STOP))
    bad[6] ^= 1
    with pytest.raises(ValueError, match="CRC"):
        decode_command(bytes(bad))
    with pytest.raises(ValueError, match="11 bytes"):
        decode_command(b"\xa5\x5a")
    with pytest.raises(ValueError, match="header"):
        decode_command(encode_v2([[1]], 0, 0)[:11])


@pytest.mark.parametrize("shape", [(1, 1), (16, 16), (3, 5), (64, 64)])
def test_round_trip(shape, rng):
    n = 20
    sent = rng.integers(0, 4096, (n, *shape))
    t0 = 1_000
    data = b"".join(encode_v2(f, 100 + i, t0 + 6061 * i) for i, f in enumerate(sent))
    dec = V2Decoder()
    events = dec.feed(data)
    assert [e.valid for e in events] == [True] * n
    np.testing.assert_array_equal(np.stack([e.data for e in events]), sent)
    assert [e.seq for e in events] == list(range(100, 100 + n))
    assert [e.t_us for e in events] == [t0 + 6061 * i for i in range(n)]
    assert all(e.data.dtype == np.uint16 and e.kind == "psm" for e in events)
    out = decode_v2(data)
    np.testing.assert_array_equal(out["frames"], sent)
    assert out["valid"].all() and out["dropped"] == 0


def test_imu_round_trip(rng):
    sent = rng.uniform(-180, 180, (10, 5, 3)).astype(np.float32)
    data = b"".join(encode_v2(a, i, 100_000 * i, kind="imu") for i, a in enumerate(sent))
    out = decode_v2(data, kind="imu")
    np.testing.assert_array_equal(out["frames"], sent)
    assert out["frames"].dtype == np.float32


def test_seq_gap_counts_dropped():
    f = np.ones((2, 2), dtype=np.uint16)
    seqs = [10, 11, 14, 15, 16, 20]
    data = b"".join(encode_v2(f, s, 1000 * s) for s in seqs)
    dec = V2Decoder()
    events = dec.feed(data)
    gaps = [e for e in events if isinstance(e, Gap)]
    assert [(g.count, g.seq) for g in gaps] == [(2, 14), (3, 20)]
    assert dec.dropped == 5 and dec.frames == 6
    assert type(events[2]) is Gap and events[3].seq == 14  # the gap precedes the frame that revealed it


def test_seq_gap_across_wrap_and_restart():
    f = np.zeros((1, 1), dtype=np.uint16)
    seqs = [2**32 - 2, 2**32 - 1, 2, 3, 0, 1]   # 0 and 1 lost across the wrap; then the device restarts
    dec = V2Decoder()
    dec.feed(b"".join(encode_v2(f, s, 0) for s in seqs))
    assert dec.dropped == 2 and dec.restarts == 1 and dec.frames == 6


def test_invalid_row_fills_gap_not_dropped():
    f = np.arange(6).reshape(2, 3)
    packets = [bytearray(encode_v2(f, s, 100 * s)) for s in range(5)]
    packets[2][20] ^= 0x10                      # payload bit error: plausible header, CRC fails
    dec = V2Decoder()
    events = dec.feed(b"".join(bytes(p) for p in packets))
    assert [e.valid for e in events] == [True, True, False, True, True]
    assert events[2].seq is None and events[2].data.shape == (2, 3) and (events[2].data == 0).all()
    assert dec.invalid == 1 and dec.dropped == 0 and dec.skipped == 0


def test_t_us_unwrapped():
    f = np.zeros((1, 1), dtype=np.uint16)
    t_raw = [(2**32 - 2500 + 1000 * k) % 2**32 for k in range(6)]
    assert t_raw[3] < t_raw[2]
    data = b"".join(encode_v2(f, k, t) for k, t in enumerate(t_raw))
    events = V2Decoder().feed(data)
    t = [e.t_us for e in events]
    assert t == [2**32 - 2500 + 1000 * k for k in range(6)]
    # a second wrap much later: 70 minutes between frames still unwraps forwards
    dec = V2Decoder()
    dec.feed(encode_v2(f, 0, 4_000_000_000))
    e = dec.feed(encode_v2(f, 1, 100))[0]
    assert e.t_us == 2**32 + 100
    out = decode_v2(data)
    assert (np.diff(out["t_us"]) == 1000).all() and out["t_us"].dtype == np.int64


def test_a_frame_scanned_before_a_reply_is_not_a_wrap():
    """A reply is stamped when it is sent, a frame when its scan began: a frame sent after a reply can carry an
    earlier time. Before, the reply moved the frames' reference and that frame went 2**32 µs forwards (a box
    asked for its rate mid-stream; a fresh decoder whose first packet was the reply)."""
    f = np.zeros((1, 1), dtype=np.uint16)
    ok = encode_reply(Opcode.SET_RATE, Status.OK, "", 0, 345_123)
    data = b"".join(encode_v2(f, k, 290_000 + 10_000 * k) for k in range(5)) + ok + b"".join(
        encode_v2(f, k, 290_000 + 10_000 * k) for k in range(5, 8))
    events = V2Decoder().feed(data)
    assert [e.t_us for e in events] == [290_000 + 10_000 * k for k in range(5)] + [345_123] + [
        290_000 + 10_000 * k for k in range(5, 8)]
    events = V2Decoder().feed(ok + encode_v2(f, 0, 340_000) + encode_v2(f, 1, 360_000))
    assert [e.t_us for e in events] == [345_123, 340_000, 360_000]
    # across a wrap: the frame just after it, sent after a reply stamped later still
    t0 = 2**32 - 15_000
    events = V2Decoder().feed(encode_v2(f, 0, t0) + encode_reply(Opcode.START, Status.OK, "", 1, 7_000)
                              + encode_v2(f, 1, (t0 + 20_000) % 2**32))
    assert [e.t_us for e in events] == [t0, 2**32 + 7_000, t0 + 20_000]


def test_frames_go_forwards_across_a_restart_told_by_a_reply():
    """A device that restarts mid-stream: its first reply is placed where it was stamped (before the last
    frame); its frames still follow the last frame's (the clock over the frames is monotonic), each step the
    device's own, and replies hours apart keep the clock through a long stop of the frames."""
    f = np.zeros((1, 1), dtype=np.uint16)
    dec = V2Decoder()
    first = dec.feed(encode_v2(f, 700, 8_820_000))[0].t_us
    r = dec.feed(encode_reply(Opcode.IDENTIFY, Status.OK, "", 0, 300_500))[0]
    frames = dec.feed(encode_v2(f, 0, 300_000) + encode_v2(f, 1, 310_000))
    assert r.t_us == 300_500 and first == 8_820_000
    assert [e.t_us for e in frames] == [8_820_000 + 2**32 - 8_520_000, 8_820_000 + 2**32 - 8_510_000]
    # the frames stop for three hours (2.5 wraps); a reply every 20 minutes
    dec = V2Decoder()
    dec.feed(encode_v2(f, 0, 0))
    step = 1_200_000_000
    replies = [dec.feed(encode_reply(Opcode.IDENTIFY, Status.OK, "", k, (k * step) % 2**32))[0].t_us for k in range(1, 10)]
    assert replies == [k * step for k in range(1, 10)]
    assert dec.feed(encode_v2(f, 1, (9 * step + 5_000) % 2**32))[0].t_us == 9 * step + 5_000


def test_replies_in_v2_stream():
    f = np.zeros((2, 2), dtype=np.uint16)
    text = "device=psm fw=0.1.0 rows=16 cols=16 rate=100 proto=2 serial=0000A1B2 r_o=2200 v_ref=3.3 bits=12"
    data = encode_v2(f, 0, 5000) + encode_reply(Opcode.IDENTIFY, Status.OK, text, 1, 4990) + encode_v2(f, 1, 15000)
    dec = V2Decoder()
    events = dec.feed(data)
    assert [type(e) for e in events][1] is Reply
    r = events[1]
    assert r.opcode == Opcode.IDENTIFY and r.status == Status.OK and r.t_us == 4990 and r.offset == 26
    assert parse_identify(r.text)["rows"] == 16
    assert dec.replies == 1 and dec.frames == 2 and dec.dropped == 0
    assert events[2].t_us == 15000


def test_implausible_headers_are_garbage():
    f = np.zeros((2, 2), dtype=np.uint16)
    good = encode_v2(f, 1, 1)
    wrong_version = bytearray(good)
    wrong_version[2] = 3
    wrong_len = bytearray(good)
    wrong_len[14] = 6                             # n != 2*R*C
    command = encode_command(Opcode.START)        # type 0x10 is not a device->host packet
    dec = V2Decoder()
    events = dec.feed(bytes(wrong_version) + bytes(wrong_len) + command + good)
    assert [e.valid for e in events] == [True] and dec.invalid == 0
    assert dec.skipped == 2 * len(good) + len(command)


def test_parse_identify():
    info = parse_identify(b"device=psm fw=0.1.0 rows=16 cols=16 rate=100 proto=2 serial=0000A1B2 "
                          b"r_o=2200 v_ref=3.3 bits=12")
    assert info == {"device": "psm", "fw": "0.1.0", "rows": 16, "cols": 16, "rate": 100, "proto": 2,
                    "serial": "0000A1B2", "r_o": 2200.0, "v_ref": 3.3, "bits": 12}
    assert parse_identify(format_identify(info)) == info
    assert parse_identify("serial=00001234")["serial"] == "00001234"
    assert parse_identify("") == {}
    for bad, msg in [("rows=16  cols=16", "key=value"), ("rows", "key=value"), ("=3", "key=value"),
                     ("rows=x", "number"), ("a=1 a=2", "repeated"), ("dev=ps\u00e9", "ASCII")]:
        with pytest.raises(ValueError, match=msg):
            parse_identify(bad)
    with pytest.raises(TypeError):
        parse_identify(16)


def test_encode_errors():
    with pytest.raises(TypeError, match="integer"):
        encode_v2(np.zeros((2, 2)), 0, 0)
    with pytest.raises(ValueError, match=r"\[0, 65535\]"):
        encode_v2([[70000]], 0, 0)
    with pytest.raises(ValueError, match="shape"):
        encode_v2([1, 2], 0, 0)
    with pytest.raises(ValueError, match="rows/cols"):
        encode_v2(np.zeros((256, 1), dtype=np.int64), 0, 0)
    with pytest.raises(ValueError, match="8192"):
        encode_v2(np.zeros((65, 64), dtype=np.int64), 0, 0)
    with pytest.raises(ValueError, match="kind"):
        encode_v2([[1]], 0, 0, kind="xyz")
    with pytest.raises(ValueError, match="seq must be >= 0"):
        encode_v2([[1]], -1, 0)
    with pytest.raises(TypeError, match="t_us must be an integer"):
        encode_v2([[1]], 0, 1.5)
    with pytest.raises(ValueError, match="finite"):
        encode_v2(np.full((5, 3), np.inf), 0, 0, kind="imu")
    assert encode_v2([[1]], 2**32 + 5, 2**33 + 7) == encode_v2([[1]], 5, 7)   # counters wrap
    with pytest.raises(ValueError, match="opcode"):
        encode_command(256)
    with pytest.raises(ValueError, match="arg"):
        encode_command(Opcode.SET_RATE, 2**32)
    with pytest.raises(ValueError, match="ASCII"):
        encode_reply(4, 0, "\u00e9")
    with pytest.raises(ValueError, match="row"):
        cal_hold_arg(256, 0)
