"""CRC-16/CCITT-FALSE, the check of protocol v2 and of the host commands (docs/protocol.md).

Polynomial 0x1021, initial value 0xFFFF, no input/output reflection, no final XOR; the
catalogue check value is ``crc16(b"123456789") == 0x29B1``.

Three implementations of the same function:

* :func:`crc16` - the one the decoders use: :func:`binascii.crc_hqx` (C, the same
  non-reflected 0x1021 register) started at 0xFFFF;
* :func:`crc16_table` - the table-driven byte-at-a-time reference, the algorithm the
  firmware core uses (:data:`CRC16_TABLE` is its table);
* :func:`crc16_frames` - vectorised with NumPy over many equal-length messages at once
  (one table look-up per byte position for all messages).
"""

from __future__ import annotations

import binascii

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["CRC16_INIT", "CRC16_POLY", "CRC16_TABLE", "crc16", "crc16_table", "crc16_frames"]

#: Generator polynomial (x^16 + x^12 + x^5 + 1, MSB-first form).
CRC16_POLY: int = 0x1021
#: Initial register value.
CRC16_INIT: int = 0xFFFF


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


def _as_bytes(data: object) -> bytes | bytearray | memoryview:
    if isinstance(data, (bytes, bytearray, memoryview)):
        return data
    raise TypeError(f"data must be bytes-like, got {type(data).__name__}")


def crc16(data: bytes | bytearray | memoryview, init: int = CRC16_INIT) -> int:
    """CRC-16/CCITT-FALSE of ``data``.

    Parameters
    ----------
    data : bytes-like
        The message.
    init : int
        Register value to start from (default 0xFFFF); pass a previous result to continue a
        CRC over a message delivered in pieces.

    Returns
    -------
    int
        The CRC, 0 ... 0xFFFF.
    """
    return binascii.crc_hqx(_as_bytes(data), init)


def crc16_table(data: bytes | bytearray | memoryview, init: int = CRC16_INIT) -> int:
    """Table-driven pure-Python CRC-16/CCITT-FALSE (reference; same result as :func:`crc16`)."""
    reg = init & 0xFFFF
    table = _TABLE
    for b in bytes(_as_bytes(data)):
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
