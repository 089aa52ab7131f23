"""CRC-16 of spans of a stream at a bounded cost per byte, however the spans overlap.

A v2 decoder must check the CRC of every plausible header, and the packets that garbage or
an attacker's fake headers claim may overlap: headers every 18 bytes claiming 8 KiB
payloads would make a plain decoder read each byte some 450 times. :class:`SpanCrc`
answers ``crc16(stream[a:b])`` for spans judged in order of their start ``a``:

* a span starting at or after the end of the last span read directly is read directly
  (a valid stream costs one pass, one :func:`~psmat.protocol.crc16` call per packet);
* an overlapping span is computed from two prefix registers of a *chain*,
  ``R(x) = crc16(stream[o:x], 0)`` kept at every ``STRIDE``-th offset from its origin
  ``o``: with ``L = b - a``, ``crc16(stream[a:b]) = crc16_shift(R(a) ^ 0xFFFF, L) ^ R(b)``
  (the register is linear in its initial value, docs/protocol.md). Each query reads fewer
  than ``STRIDE`` bytes beyond the chain, the chain reads each byte once, and a new chain
  starts only past the end of the previous one.

So the bytes run through the CRC (:attr:`SpanCrc.bytes`) are at most twice the stream's
length plus ``2 * STRIDE`` per overlapping span, whatever the input.
"""

from __future__ import annotations

import binascii

from ._crc import CRC16_INIT, _mulmod, _x_pow_bytes

__all__ = ["SpanCrc"]


class SpanCrc:
    """CRC-16/CCITT-FALSE of spans of a stream held in a sliding buffer.

    The caller keeps the stream in a ``bytearray`` whose first byte is at stream offset
    ``base``; spans are given in stream offsets, their starts non-decreasing. Before
    dropping the head of its buffer the caller asks :meth:`keep_from` how much it must keep.

    Attributes
    ----------
    bytes : int
        Bytes run through the CRC so far (the work done).
    """

    #: Distance between two registers of the chain (bytes).
    STRIDE: int = 16

    def __init__(self) -> None:
        self._direct_end = 0      # stream offset where the last directly read span ends
        self._origin = 0          # stream offset of the chain's first register
        self._regs: list[int] = []
        self.bytes = 0

    def crc(self, buf: bytearray, base: int, a: int, b: int) -> int:
        """CRC-16/CCITT-FALSE of ``stream[a:b]`` (``base <= a <= b <= base + len(buf)``)."""
        if a >= self._direct_end:
            self._direct_end = b
            self.bytes += b - a
            return binascii.crc_hqx(buf[a - base:b - base], CRC16_INIT)
        regs = self._regs
        if not regs or a > self._origin + (len(regs) - 1) * self.STRIDE:
            self._origin, self._regs = a, [0]       # past the chain's end: a new chain
            ra = 0
        else:
            ra = self._register(buf, base, a)
        rb = self._register(buf, base, b)
        return _mulmod(ra ^ CRC16_INIT, _x_pow_bytes(b - a)) ^ rb   # crc16_shift without its checks

    def keep_from(self, new_base: int) -> int:
        """Stream offset from which the buffer must be kept when it is cut at ``new_base``.

        At most ``STRIDE - 1`` bytes before ``new_base`` (the chain's register at or before
        it); the chain is dropped when it ends before ``new_base``.
        """
        regs = self._regs
        if not regs:
            return new_base
        i = (new_base - self._origin) // self.STRIDE
        if i >= len(regs):
            regs.clear()
            return new_base
        if i > 0:
            del regs[:i]
            self._origin += i * self.STRIDE
        return min(self._origin, new_base)

    def _register(self, buf: bytearray, base: int, x: int) -> int:
        """Chain register ``crc16(stream[origin:x], 0)`` (``x >= origin``)."""
        regs, step, crc_hqx = self._regs, self.STRIDE, binascii.crc_hqx
        i, rest = divmod(x - self._origin, step)
        n = len(regs)
        if n <= i:
            p = self._origin + (n - 1) * step - base
            reg = regs[-1]
            for _ in range(i + 1 - n):
                reg = crc_hqx(buf[p:p + step], reg)
                regs.append(reg)
                p += step
            self.bytes += (i + 1 - n) * step
        if not rest:
            return regs[i]
        p = self._origin + i * step - base
        self.bytes += rest
        return crc_hqx(buf[p:p + rest], regs[i])
