"""CRC-16/CCITT-FALSE, the check of protocol v2 and of the host commands (docs/protocol.md).

Polynomial 0x1021, initial value 0xFFFF, no input/output reflection, no final XOR; the
catalogue check value is ``crc16(b"123456789") == 0x29B1``.

:func:`crc16` is :func:`binascii.crc_hqx` (C, the same non-reflected 0x1021 register)
started at 0xFFFF. The tests hold independent references (tests/crc_reference.py: bit-serial,
table-driven as in the firmware core, vectorised over messages).
"""

from __future__ import annotations

import binascii

__all__ = ["CRC16_INIT", "CRC16_POLY", "crc16"]

#: Generator polynomial (x^16 + x^12 + x^5 + 1, MSB-first form).
CRC16_POLY: int = 0x1021
#: Initial register value.
CRC16_INIT: int = 0xFFFF


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
