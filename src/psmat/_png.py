"""Whether bytes are a well-formed PNG file, read as data (nothing decoded, nothing run).

Used where a picture crosses a line of trust: a figure or a report page drawn by a Dask worker
(:mod:`psmat.study` (``_cluster.py``)). Imports nothing but the standard library.
"""

from __future__ import annotations

import zlib

__all__ = ["PNG_SIGNATURE", "check_png"]

#: the eight bytes every PNG file begins with (PNG specification, §5.2)
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: the largest PNG accepted (bytes): a study's figure is well under 1 MiB
MAX_PNG_BYTES = 64 << 20


def check_png(data: object) -> bytes:
    """``data`` when it is one PNG file and nothing else, else ValueError (one line).

    Checked: the signature; then chunks of a 4-byte big-endian length (< 2**31), a 4-letter
    ASCII type, the data and its CRC-32 over type and data; ``IHDR`` first (13 bytes, width and
    height >= 1), ``IEND`` last (empty), ending exactly at the end of ``data``; at most
    :data:`MAX_PNG_BYTES`.
    """
    if not isinstance(data, (bytes, bytearray)):
        raise ValueError(f"a PNG must be bytes, got {type(data).__name__}")
    b = bytes(data)
    if len(b) > MAX_PNG_BYTES:
        raise ValueError(f"a PNG of {len(b)} bytes, more than {MAX_PNG_BYTES}")
    if not b.startswith(PNG_SIGNATURE):
        raise ValueError("not a PNG (no PNG signature)")
    pos, first = len(PNG_SIGNATURE), True
    while True:
        if pos + 12 > len(b):
            raise ValueError(f"PNG cut short at byte {pos} (no IEND)")
        n = int.from_bytes(b[pos:pos + 4], "big")
        kind = b[pos + 4:pos + 8]
        if n >= 1 << 31 or pos + 12 + n > len(b):
            raise ValueError(f"PNG chunk at byte {pos}: length {n} past the end")
        if not kind.isalpha() or not kind.isascii():
            raise ValueError(f"PNG chunk at byte {pos}: type {kind!r} is not four ASCII letters")
        body = b[pos + 8:pos + 8 + n]
        if zlib.crc32(kind + body) != int.from_bytes(b[pos + 8 + n:pos + 12 + n], "big"):
            raise ValueError(f"PNG chunk {kind.decode()} at byte {pos}: CRC mismatch")
        if first and (kind != b"IHDR" or n != 13 or int.from_bytes(body[:4], "big") == 0
                      or int.from_bytes(body[4:8], "big") == 0):
            raise ValueError("PNG without IHDR (13 bytes, width and height >= 1) first")
        first = False
        pos += 12 + n
        if kind == b"IEND":
            if n != 0 or pos != len(b):
                raise ValueError("PNG with data in or after IEND")
            return b
