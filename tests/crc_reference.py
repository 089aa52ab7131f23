"""Independent CRC-16/CCITT-FALSE references for the protocol tests (not the code under test):
bit-serial, table-driven byte at a time (the firmware core's algorithm), and vectorised over
many equal-length messages with NumPy."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

CRC16_POLY = 0x1021
CRC16_INIT = 0xFFFF


def crc_bitwise(data: bytes) -> int:
    """Bit-serial CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, MSB first, no reflection, no xorout."""
    reg = 0xFFFF
    for byte in data:
        for i in range(7, -1, -1):
            feedback = ((reg >> 15) & 1) ^ ((byte >> i) & 1)
            reg = (reg << 1) & 0xFFFF
            if feedback:
                reg ^= 0x1021
    return reg


def _make_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        reg = byte << 8
        for _ in range(8):
            reg = ((reg << 1) ^ CRC16_POLY) if reg & 0x8000 else (reg << 1)
            reg &= 0xFFFF
        table.append(reg)
    return tuple(table)


_TABLE: tuple[int, ...] = _make_table()
#: The 256-entry look-up table, ``CRC16_TABLE[b]`` = register after shifting byte ``b``
#: through a zero register (uint16, read-only).
CRC16_TABLE: NDArray[np.uint16] = np.array(_TABLE, dtype=np.uint16)
CRC16_TABLE.setflags(write=False)


def crc16_table(data: bytes | bytearray | memoryview, init: int = CRC16_INIT) -> int:
    """Table-driven pure-Python CRC-16/CCITT-FALSE (reference; same result as :func:`crc16`)."""
    reg = init & 0xFFFF
    table = _TABLE
    for b in bytes(data):
        reg = ((reg << 8) & 0xFFFF) ^ table[(reg >> 8) ^ b]
    return reg


def crc16_frames(messages: ArrayLike, init: int = CRC16_INIT) -> NDArray[np.uint16]:
    """CRC-16/CCITT-FALSE of many equal-length messages at once.

    Parameters
    ----------
    messages : array_like of uint8, shape (N, L)
        ``N`` messages of ``L`` bytes each (a 1-D array is one message).

    Returns
    -------
    ndarray of uint16, shape (N,)
        One CRC per message (shape ``()`` for a 1-D input).
    """
    arr = np.asarray(messages)
    if arr.dtype != np.uint8:
        raise TypeError(f"messages must be a uint8 array, got dtype {arr.dtype}")
    if arr.ndim not in (1, 2):
        raise ValueError(f"messages must have shape (N, L) or (L,), got {arr.shape}")
    single = arr.ndim == 1
    arr2 = arr[None, :] if single else arr
    reg = np.full(arr2.shape[0], init & 0xFFFF, dtype=np.uint16)
    for j in range(arr2.shape[1]):
        idx = (reg >> np.uint16(8)) ^ arr2[:, j]
        reg = (reg << np.uint16(8)) ^ CRC16_TABLE[idx]
    return reg[0] if single else reg
