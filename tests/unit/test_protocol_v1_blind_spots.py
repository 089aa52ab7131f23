"""What the v1 framing's check (sum of the cells mod 4096, docs/protocol.md) cannot see, measured.

The real decoder (:class:`psmat.protocol.V1Decoder`) judges frames corrupted with a
fixed seed; what it accepts is compared with what the rule allows, worked out by hand: a
changed frame passes when every cell and the check stay <= 4095 and the cells' sum mod 4096
still equals the check. One flipped bit never passes (it changes the sum by ±2**b, b < 12,
or lifts a cell above 4095); two flips pass when they cancel: the same bit of two words,
one set and one cleared (or bit 11 either way, as 2048 + 2048 = 4096), a word being a cell
or the check.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from psmat.io import SessionWriter, info, load_session
from psmat.protocol import encode_v1, encode_v1_many
from psmat.protocol import V1Decoder

R, C = 16, 16


def _decode_one(packet: bytes) -> list:
    d = V1Decoder((R, C))
    return [e for e in d.feed(packet) + d.finish() if getattr(e, "valid", False)]


def test_two_swapped_cells_pass_the_v1_check() -> None:
    frame = np.arange(R * C, dtype=np.uint16).reshape(R, C) * 7 % 4096
    swapped = frame.copy()
    swapped[2, 3], swapped[9, 11] = frame[9, 11], frame[2, 3]
    packet = bytearray(encode_v1(frame))
    packet[2:-2] = swapped.astype("<u2").tobytes()  # the same check bytes
    (got,) = _decode_one(bytes(packet))
    np.testing.assert_array_equal(got.data, swapped)  # accepted, with the two cells swapped
    assert not np.array_equal(got.data, frame)


def test_bit_errors_at_1e_4_that_pass_the_v1_check_are_what_the_sum_allows() -> None:
    n, ber = 13262, 1e-4
    rng = np.random.default_rng(20240)
    frames = rng.integers(0, 4096, size=(n, R, C), dtype=np.uint16)
    size = 4 + 2 * R * C
    raw = np.frombuffer(encode_v1_many(frames), np.uint8).reshape(n, size).copy()
    nbits = (size - 2) * 8  # cells and check; the FF FF start is left alone (a frame, not its framing)
    pos = np.unique(rng.integers(0, n * nbits, size=rng.binomial(n * nbits, ber)))
    frame_no, bit = np.divmod(pos, nbits)
    np.bitwise_xor.at(raw, (frame_no, 2 + bit // 8), (1 << (bit % 8)).astype(np.uint8))
    hit = np.unique(frame_no)
    accepted = [int(i) for i in hit if _decode_one(raw[i].tobytes())]
    # the rule, applied to the received bytes
    cells = raw[:, 2:-2].copy().view("<u2")
    check = raw[:, -2:].copy().view("<u2")[:, 0]
    passes = (cells.max(axis=1) <= 4095) & (check <= 4095) & ((cells.sum(axis=1, dtype=np.int64) & 0xFFF) == check)
    assert accepted == [int(i) for i in hit if passes[i]]
    # by hand: every accepted frame has exactly two flips, at the same bit (< 12) of two words
    for i in accepted:
        b = bit[frame_no == i]
        word_bit = ((b // 8) % 2) * 8 + b % 8  # the bit within its little-endian 16-bit word
        assert b.size == 2 and word_bit[0] == word_bit[1] < 12 and b[0] // 16 != b[1] // 16, (i, b)
    print(f"v1 at BER {ber:g}, seed 20240: {hit.size} of {n} frames corrupted, {len(accepted)} passed the check")
    assert accepted  # the blind spot is real at this seed (docs/protocol.md quotes the count)


def test_info_on_a_v1_session_says_what_its_check_cannot_see(tmp_path: Path) -> None:
    p = tmp_path / "v1.h5"
    with SessionWriter(p, (R, C), {"serial": "OLD1", "proto": 1}) as w:
        w.append(np.zeros((3, R, C)), np.arange(3) / 100, np.ones(3, bool))  # v1: no sequence numbers
    text = info(load_session(p))
    assert "protocol v1" in text and "two cells swapped" in text and "mod 4096" in text
    assert "lost          unknown" in text
    p2 = tmp_path / "v2.h5"
    with SessionWriter(p2, (R, C), {"serial": "NEW1", "proto": 2}) as w:
        w.append(np.zeros((3, R, C)), np.arange(3) / 100, np.ones(3, bool), seq=np.arange(3))
    assert "protocol v1" not in info(load_session(p2))
