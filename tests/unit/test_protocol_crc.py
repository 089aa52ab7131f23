"""CRC-16/CCITT-FALSE against an independent bit-serial implementation (docs/protocol.md)."""

from __future__ import annotations

import numpy as np
import pytest
from crc_reference import CRC16_TABLE, crc16_frames, crc16_table, crc_bitwise

from psmat.protocol import crc16




@pytest.mark.parametrize("impl", [crc16, crc16_table])
def test_check_value(impl):
    assert impl(b"123456789") == 0x29B1
    assert crc_bitwise(b"123456789") == 0x29B1  # the test's own reference agrees with the catalogue


@pytest.mark.parametrize("msg", [b"", b"A", b"\x00", b"\xff\xff", bytes(range(256)), b"A" * 256,
                                 b"\x02\x10\x03\xa5\x00\x00\x00"])
def test_known_vectors(msg):
    expected = crc_bitwise(msg)
    assert crc16(msg) == expected
    assert crc16_table(msg) == expected
    assert crc16_frames(np.frombuffer(msg, dtype=np.uint8)) == expected


def test_catalogue_vectors():
    assert crc16(b"") == 0xFFFF            # no final XOR: the empty message leaves the init value
    assert crc_bitwise(b"A") == 0xB915     # widely published CRC-16/CCITT-FALSE("A")
    assert crc16(b"A") == 0xB915


def test_random_messages_and_incremental(rng):
    for length in (1, 2, 7, 64, 530):
        msg = rng.integers(0, 256, length, dtype=np.uint8).tobytes()
        assert crc16(msg) == crc16_table(msg) == crc_bitwise(msg)
        cut = length // 2
        assert crc16(msg[cut:], crc16(msg[:cut])) == crc16(msg)


def test_table_first_entries():
    assert CRC16_TABLE[0] == 0 and CRC16_TABLE[1] == 0x1021 and CRC16_TABLE[0x80] == 0x9188
    assert CRC16_TABLE.dtype == np.uint16 and CRC16_TABLE.shape == (256,)
    with pytest.raises(ValueError):
        CRC16_TABLE[0] = 1


def test_vectorised(rng):
    msgs = rng.integers(0, 256, (50, 33), dtype=np.uint8)
    out = crc16_frames(msgs)
    assert out.dtype == np.uint16 and out.shape == (50,)
    assert [int(v) for v in out] == [crc_bitwise(m.tobytes()) for m in msgs]
    assert crc16_frames(np.zeros((3, 0), dtype=np.uint8)).tolist() == [0xFFFF] * 3


def test_bad_input():
    with pytest.raises(TypeError, match="bytes-like"):
        crc16("123456789")
