"""Reading a finished session file that was cut short (docs/spec.md §6).

A copy or a download that stopped, a full disk or a file system that lost a file's tail leave
a session file shorter than the end-of-file address its HDF5 superblock records, and HDF5
refuses to open it (``truncated file: eof = N, sblock->base_addr = 0, stored_eof = M``). A
session file keeps all of its HDF5 metadata before its frames
(:func:`psmat.io.session._build.write_session_file`), so a cut usually costs trailing chunks
only. The loader reads the superblock itself (:func:`recorded_size`), opens the file as if
its missing tail were zeros (:class:`PaddedFile`: nothing is copied or written) and treats
every chunk stored wholly or partly past the cut as lost (:func:`chunk_lost`): its frames
load invalid, noted ``file truncated at byte N of M: frames a..b lost``. A cut inside the
metadata leaves a file that does not open (every metadata block of a session file carries a
checksum, which zeros fail): one :class:`SessionFormatError`.

Superblock (HDF5 file format specification, "Superblock"): the signature
``\\x89HDF\\r\\n\\x1a\\n``, then the version byte. Versions 0 and 1 keep the size of offsets
``O`` at byte 13 and, after 24 (version 0) or 28 (version 1) bytes, the base address, the
free-space address and the end-of-file address, ``O`` bytes each; versions 2 and 3 keep
``O`` at byte 9 and, from byte 12, the base address, the superblock extension address and
the end-of-file address. Addresses are little-endian and relative to the base address.
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import Any

import h5py

from ._layout import SessionFormatError

#: the HDF5 file signature, which begins the superblock
SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: how the loader's note on a file cut short begins (:func:`lost_note`)
TRUNCATED = "file truncated at byte "
#: how far (bytes) the recorded end of a cut file may lie past the end of the furthest stored
#: chunk or array: HDF5 ends a file where its last allocation ends, so anything more is not a
#: session file cut short but a forged size
_SLACK = 4096


def recorded_size(head: bytes) -> int | None:
    """The size (bytes) that the superblock at the start of ``head`` records, or None.

    Parameters
    ----------
    head : bytes
        The first bytes of the file (64 are enough for every superblock version).

    Returns
    -------
    int or None
        Base address plus end-of-file address; None when ``head`` does not begin with a
        superblock this module reads (no signature, an unknown version, an undefined address).
    """
    if not head.startswith(SIGNATURE) or len(head) < 16:
        return None
    version = head[8]
    if version in (0, 1):
        o, base_at = head[13], 24 if version == 0 else 28
    elif version in (2, 3):
        o, base_at = head[9], 12
    else:
        return None
    eof_at = base_at + 2 * o
    if o not in (2, 4, 8) or len(head) < eof_at + o:
        return None
    base = int.from_bytes(head[base_at : base_at + o], "little")
    eof = int.from_bytes(head[eof_at : eof_at + o], "little")
    undefined = (1 << (8 * o)) - 1
    if base == undefined or eof == undefined:
        return None
    return base + eof


def truncation(path: Path) -> tuple[int, int] | None:
    """``(bytes held, bytes recorded)`` when the file at ``path`` is shorter than its superblock says, else None."""
    with open(path, "rb") as fh:
        size = os.fstat(fh.fileno()).st_size
        head = fh.read(64)
    rec = recorded_size(head)
    return (size, rec) if rec is not None and rec > size else None


class PaddedFile(io.RawIOBase):
    """The file at ``path`` read as ``size`` bytes: its own, then zeros (for h5py's ``fileobj`` driver).

    Nothing is copied or written; the zeros are made as HDF5 reads them, so memory stays that
    of one read. ``repr`` is the path, which h5py reports as the file's name.
    """

    def __init__(self, path: Path, size: int) -> None:
        super().__init__()
        self.path = Path(path)
        self._fh = open(self.path, "rb")  # noqa: SIM115 - closed by close()
        self.real = os.fstat(self._fh.fileno()).st_size
        self.size = int(size)
        self._pos = 0

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        base = {io.SEEK_SET: 0, io.SEEK_CUR: self._pos, io.SEEK_END: self.size}[whence]
        self._pos = max(base + int(offset), 0)
        return self._pos

    def tell(self) -> int:
        return self._pos

    def readinto(self, buffer: Any) -> int:
        mv = memoryview(buffer).cast("B")
        n = max(min(len(mv), self.size - self._pos), 0)
        got = 0
        if self._pos < self.real and n:
            self._fh.seek(self._pos)
            got = self._fh.readinto(mv[: min(n, self.real - self._pos)]) or 0
        mv[got:n] = bytes(n - got)
        self._pos += n
        return n

    def close(self) -> None:
        if not self.closed:
            self._fh.close()
        super().close()

    def __repr__(self) -> str:
        return str(self.path)


def _storage_end(ds: h5py.Dataset) -> int:
    """The end (byte address) of the furthest byte of ``ds``'s data stored in the file; 0 if none."""
    if ds.chunks is None:
        off = ds.id.get_offset()
        return 0 if off is None else int(off) + int(ds.id.get_storage_size())  # compact: in its header
    ends = [0]
    ds.id.chunk_iter(lambda info: ends.append(int(info.byte_offset) + int(info.size)))
    return max(ends)


def check_recorded_size(f: h5py.File, path: Path, cut: tuple[int, int]) -> None:
    """SessionFormatError unless the size the superblock records is where the datasets' storage ends.

    ``cut``: ``(bytes held, bytes recorded)``. The zeros the loader reads past the cut must be
    storage the datasets claim, so that what it allocates stays bounded by what the file's own
    metadata says it holds (:func:`psmat.io.session._storage.check_objects` bounds their sum).
    """
    real, recorded = cut
    ends = [real]
    f.visititems(lambda _name, obj: ends.append(_storage_end(obj)) if isinstance(obj, h5py.Dataset) else None)
    end = max(ends)  # each object once (HDF5's own visit), however many links lead to it
    if recorded > end + _SLACK:
        raise SessionFormatError(f"{path}: {real} bytes, but its superblock records {recorded} and its datasets "
                                 f"are stored up to byte {end}: not a session file cut short")


def array_lost(ds: h5py.Dataset, held: int) -> bool:
    """True when the data of the unchunked ``ds`` are not stored within the first ``held`` bytes."""
    off = ds.id.get_offset()
    return off is not None and int(off) + int(ds.id.get_storage_size()) > held


def chunk_lost(ds: h5py.Dataset, row: int, held: int) -> bool:
    """True when the chunk of ``ds`` holding row ``row`` is not stored within the first ``held`` bytes."""
    info = ds.id.get_chunk_info_by_coord((int(row),) + (0,) * (ds.ndim - 1))
    return info.byte_offset is None or int(info.byte_offset) + int(info.size) > held


def lost_note(cut: tuple[int, int], lost: str) -> str:
    """``file truncated at byte N of M: frames a..b lost`` (``lost``: the frames, as ranges, or "none")."""
    return f"{TRUNCATED}{cut[0]} of {cut[1]}: " + ("no frames lost" if lost == "none"
                                                                else f"frames {lost} lost")
