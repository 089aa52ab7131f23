"""CRC-32 of a session file's chunks, bound to the dataset and the position they belong to.

HDF5's Fletcher-32 filter sums 16-bit words modulo 65535, where ``0x0000`` and ``0xFFFF`` are
the same number: a word changed from one to the other passes it, and a whole chunk moved to
another position (with its own checksum) passes it too. So every per-frame dataset of a
session also carries one CRC-32 (zlib's) per chunk of ``c`` frames, over

    the dataset's HDF5 path (UTF-8), one NUL byte, the chunk's index as int64 little-endian,
    then the chunk's rows as stored (C order, little-endian; the last chunk only its rows),

kept in the table ``crc32/NAME`` (uint32, one entry per chunk) next to the dataset. CRC-32
sees every error burst of up to 32 bits, so every ``00 00`` <-> ``FF FF`` word, and the path
and index in it tell a chunk that was moved from one that belongs where it is. A single-chunk
dataset (``counters``, ``/products/NAME``) carries its CRC-32 (index 0) as the attribute
``crc32``. Any program can check them with ``zlib.crc32`` or an equivalent.
"""

from __future__ import annotations

import zlib
from typing import Any

import numpy as np
from numpy.typing import NDArray

#: the name of the group of CRC tables in a device's group, and of a single-chunk dataset's attribute
CRC_NAME = "crc32"


def _le(a: NDArray[Any]) -> NDArray[Any]:
    """``a`` C-contiguous and little-endian (as HDF5 stores psmat's datasets)."""
    return np.ascontiguousarray(a, dtype=a.dtype.newbyteorder("<"))


def chunk_crc(name: str, index: int, rows: NDArray[Any]) -> int:
    """CRC-32 of chunk ``index`` of the dataset at HDF5 path ``name`` holding ``rows``."""
    crc = zlib.crc32(name.encode("utf-8") + b"\0" + int(index).to_bytes(8, "little", signed=True))
    return zlib.crc32(_le(rows), crc)


class ChunkCrcs:
    """CRC-32 per chunk of ``chunk_rows`` rows of the dataset at ``name``, fed rows in order (any batch sizes).

    Streaming: nothing is buffered, so a writer computes the table while it writes the rows.
    """

    def __init__(self, name: str, chunk_rows: int, dtype: np.dtype) -> None:
        if chunk_rows < 1:
            raise ValueError(f"chunk_rows must be >= 1, got {chunk_rows}")
        self.name = name
        self.chunk_rows = int(chunk_rows)
        self.dtype = np.dtype(dtype)
        self._crcs: list[int] = []
        self._crc = 0
        self._filled = 0  # rows of the current chunk fed so far

    def feed(self, rows: Any) -> None:
        """The next rows of the dataset (converted to its stored dtype, as HDF5 would)."""
        a = np.asarray(rows, dtype=self.dtype)
        k = 0
        while k < a.shape[0]:
            if self._filled == 0:
                self._crc = chunk_crc(self.name, len(self._crcs), a[:0])
            m = min(self.chunk_rows - self._filled, a.shape[0] - k)
            self._crc = zlib.crc32(_le(a[k : k + m]), self._crc)
            self._filled += m
            k += m
            if self._filled == self.chunk_rows:
                self._crcs.append(self._crc)
                self._filled = 0

    def table(self) -> NDArray[np.uint32]:
        """One CRC-32 per chunk, the last (partial) chunk included."""
        tail = [self._crc] if self._filled else []
        return np.array(self._crcs + tail, dtype="<u4")
