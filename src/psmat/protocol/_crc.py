"""CRC-16/CCITT-FALSE, the check of protocol v2 and of the host commands (docs/protocol.md).

Polynomial 0x1021, initial value 0xFFFF, no input/output reflection, no final XOR; the
catalogue check value is ``crc16(b"123456789") == 0x29B1``.

:func:`crc16` is :func:`binascii.crc_hqx` (C, the same non-reflected 0x1021 register)
started at 0xFFFF. The tests hold independent references (tests/crc_reference.py: bit-serial,
table-driven as in the firmware core, vectorised over messages).

:func:`crc16_shift` advances a register over ``n`` zero bytes in O(log n) (the register is
multiplied by ``x**(8n)`` modulo the polynomial), which lets :mod:`._span_crc`
check the CRC of any span of a stream from two prefix registers instead of re-reading it.
"""

from __future__ import annotations

import binascii
from functools import lru_cache

__all__ = ["CRC16_INIT", "CRC16_POLY", "crc16", "crc16_shift"]

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


def _mulmod(a: int, b: int) -> int:
    """Product of two 16-bit polynomials over GF(2), modulo x^16 + x^12 + x^5 + 1."""
    r = 0
    while b:
        if b & 1:
            r ^= a
        b >>= 1
        a <<= 1
        if a & 0x10000:
            a ^= 0x10000 | CRC16_POLY
    return r


@lru_cache(maxsize=1 << 14)
def _x_pow_bytes(n: int) -> int:
    """``x**(8n)`` modulo the polynomial (square and multiply)."""
    result, square = 1, 0x0100           # x^0, x^8
    while n:
        if n & 1:
            result = _mulmod(result, square)
        square = _mulmod(square, square)
        n >>= 1
    return result


def crc16_shift(reg: int, n: int) -> int:
    """The register ``reg`` after ``n`` zero bytes: ``crc16(bytes(n), reg)`` in O(log n).

    Parameters
    ----------
    reg : int
        Register value, 0 ... 0xFFFF.
    n : int
        Number of zero bytes, >= 0.

    Returns
    -------
    int
        ``reg * x**(8n)`` modulo the generator polynomial (the CRC has no final XOR, so a
        message's register is linear in the initial value: ``crc16(m, a) ^ crc16(m, b) ==
        crc16_shift(a ^ b, len(m))``).
    """
    if not 0 <= reg <= 0xFFFF:
        raise ValueError(f"reg must lie in [0, 0xFFFF], got {reg}")
    if n < 0:
        raise ValueError(f"n must be >= 0, got {n}")
    return _mulmod(reg, _x_pow_bytes(n))
