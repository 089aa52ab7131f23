"""What a session file may hold, checked before any of its data is read (docs/spec.md §6).

A session file received from elsewhere is untrusted: HDF5 can keep a dataset's bytes in
another file (external storage, which may name ``/etc/passwd``), assemble it from other
files (a virtual dataset), link to other files or paths (external and soft links), or pass
its chunks through filters that run code. A psmat session holds none of these: only groups
and plain datasets (compact, contiguous or chunked) of numbers stored in the file itself,
chunked ones with Fletcher-32 as their only filter, every chunk of their extent stored. Each
check here raises one :class:`SessionFormatError` naming the file and the object; none of
them reads a dataset's data, so a file that fails is never read.

The data a file can make the loader hold is bounded by the file's size: the datasets' stored
bytes, summed, may not exceed it (HDF5 reports a dataset's storage from its own index, so
a crafted index can claim more), and a dataset must store every chunk of its extent (an
unstored chunk would read as the fill value: frames that are not there).
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import h5py
import numpy as np

from ._layout import KINDS, PER_FRAME, PER_FRAME_SPEC, SessionFormatError, frame_shape_of

_PLAIN_LAYOUTS = {h5py.h5d.COMPACT: "compact", h5py.h5d.CONTIGUOUS: "contiguous", h5py.h5d.CHUNKED: "chunked"}
#: the only filter psmat writes (docs/spec.md §6)
_FILTERS = {h5py.h5z.FILTER_FLETCHER32}
_MAX_OBJECTS = 1 << 16  # far more groups and datasets than any session has
_FRAME_DATASETS = frozenset({*(k.dataset for k in KINDS.values()), *PER_FRAME})


def check_objects(f: h5py.File, path: Path, *, stored: bool, size: int | None = None) -> None:
    """Every object of ``f``: a group, or a dataset that :func:`check_dataset` accepts; links hard.

    ``stored``: require every dataset to store its whole extent. False for a format-1 file
    whose writer was killed, whose frame and per-frame datasets may have rows beyond what it
    committed (:func:`check_device` checks the committed ones); its other datasets must
    still be whole. ``size``: the file's size in bytes (default: on disk; for a file cut
    short, the size its superblock records, :mod:`._truncated`).
    """
    size = path.stat().st_size if size is None else int(size)
    seen = {h5py.h5o.get_info(f.id).addr}  # object header addresses: a hard link back up is not a cycle
    total = 0
    todo: list[h5py.Group] = [f]
    while todo:
        g = todo.pop()
        for name in g:
            link = g.get(name, getlink=True)
            where = f"{g.name.rstrip('/')}/{name}"
            if not isinstance(link, h5py.HardLink):
                kind = {h5py.SoftLink: "a soft link", h5py.ExternalLink: "an external link"}.get(type(link), "a link")
                target = (f" to {link.filename}:{link.path}" if isinstance(link, h5py.ExternalLink)
                          else f" to {link.path}" if isinstance(link, h5py.SoftLink) else "")
                raise SessionFormatError(f"{path}: {where} is {kind}{target}; a session file holds only groups "
                                         "and datasets stored in it")
            obj = g[name]
            addr = h5py.h5o.get_info(obj.id).addr
            if addr in seen:
                continue
            seen.add(addr)
            if len(seen) > _MAX_OBJECTS:
                raise SessionFormatError(f"{path}: more than {_MAX_OBJECTS} objects, not a psmat session")
            if isinstance(obj, h5py.Group):
                todo.append(obj)
            elif isinstance(obj, h5py.Dataset):
                # /events/host_time_s is named like a per-frame dataset but is never a frame's
                total += check_dataset(obj, path, size,
                                       stored=stored or name not in _FRAME_DATASETS or g.name == "/events")
                if total > size:
                    raise SessionFormatError(f"{path}: its datasets claim {total} bytes of storage, more than the "
                                             f"file's {size} bytes (a forged chunk index)")
            else:
                raise SessionFormatError(f"{path}: {where} is a {type(obj).__name__}, not a group or a dataset")


def check_dataset(ds: h5py.Dataset, path: Path, file_size: int, *, stored: bool = True) -> int:
    """Check one dataset's storage and type (module docstring); return its stored bytes."""
    where = f"{path}: dataset {ds.name}"
    plist = ds.id.get_create_plist()
    layout = plist.get_layout()
    if layout == h5py.h5d.VIRTUAL:
        raise SessionFormatError(f"{where} is a virtual dataset (VDS, its data come from other datasets or "
                                 "files); a session file's data are stored in it")
    if layout not in _PLAIN_LAYOUTS:
        raise SessionFormatError(f"{where} has storage layout {layout}, not compact, contiguous or chunked")
    if plist.get_external_count():
        name, _offset, _size = plist.get_external(0)
        raise SessionFormatError(f"{where} uses external storage (its bytes are in {name!r}); a session "
                                 "file's data are stored in it")
    for i in range(plist.get_nfilters()):
        fid, _flags, _vals, fname = plist.get_filter(i)
        if fid not in _FILTERS:
            raise SessionFormatError(f"{where} uses filter {fid} ({fname.decode('utf-8', 'replace')!r}); "
                                     "psmat writes Fletcher-32 only")
    dt = ds.dtype
    if dt.kind not in "biuf" or dt.fields is not None or dt.subdtype is not None:
        raise SessionFormatError(f"{where} has dtype {dt}, not plain numbers")
    used = int(ds.id.get_storage_size())
    if used > file_size:
        raise SessionFormatError(f"{where} claims {used} bytes of storage in a file of {file_size} bytes")
    if stored:
        check_rows_stored(ds, path, ds.shape[0] if ds.ndim else 1)
    return used


def check_rows_stored(ds: h5py.Dataset, path: Path, n: int) -> None:
    """Rows ``[0, n)`` of ``ds`` (all of it for a scalar) are stored in the file, not left to the fill value."""
    where = f"{path}: dataset {ds.name}"
    shape = tuple(int(x) for x in ds.shape)
    if ds.chunks is None:
        want = ds.dtype.itemsize * math.prod(shape)
        got = int(ds.id.get_storage_size())
        if got < want and n > 0:
            raise SessionFormatError(f"{where} declares {want} bytes of data but stores {got}")
        return
    chunks = tuple(int(x) for x in ds.chunks)
    per_row = math.prod(-(-s // c) for s, c in zip(shape[1:], chunks[1:]))
    need = -(-n // chunks[0]) * per_row  # chunks holding rows [0, n)
    have = int(ds.id.get_num_chunks())
    if have < need:
        raise SessionFormatError(f"{where} declares {n} rows in {need} chunks but stores {have} chunks")
    if have == need and n == shape[0]:
        return  # every chunk of the extent is stored
    grid = [range(0, s_, c_) for s_, c_ in zip(shape[1:], chunks[1:])]
    for lead in range(0, n, chunks[0]):  # an interrupted format-1 file: the committed rows' chunks
        for rest in itertools.product(*grid):
            if ds.id.get_chunk_info_by_coord((lead, *rest)).byte_offset is None:
                raise SessionFormatError(f"{where}: the chunk of rows {lead}.. is not stored")


def check_device(g: h5py.Group, path: Path, kind: str, complete: bool) -> tuple[tuple[int, ...], int]:
    """A device's frame and per-frame datasets in ``g`` against its kind (:data:`KINDS`); frame shape and count.

    Checked before anything is allocated or read: the group's ``frame_shape`` attribute is a
    shape the kind allows; the frame dataset has the kind's dtype, rank and that frame shape;
    each per-frame dataset is one-dimensional with its dtype (:data:`PER_FRAME_SPEC`); a
    chunked one is chunked along time only. In a complete file every dataset has the same
    length, which is the group's ``n_frames``; a format-1 file whose writer was killed has
    the rows it committed (``/committed``), each stored.
    """
    spec = KINDS[kind]
    where = f"{path}: {g.name}"
    raw = np.asarray(g.attrs.get("frame_shape", []))
    if raw.ndim != 1 or raw.dtype.kind not in "iu" or raw.size > 8:
        raise SessionFormatError(f"{where}: attribute frame_shape {raw.tolist()!r} is not a frame shape")
    try:
        fshape = frame_shape_of(kind, tuple(int(x) for x in raw))
    except ValueError as e:
        raise SessionFormatError(f"{where}: {e}") from None
    names = (spec.dataset, *PER_FRAME)
    want = {spec.dataset: (spec.dtype, fshape), **{k: (np.dtype(PER_FRAME_SPEC[k][0]), ()) for k in PER_FRAME}}
    lengths = {}
    for name in names:
        ds = g.get(name)
        if not isinstance(ds, h5py.Dataset):
            raise SessionFormatError(f"{where}: {'missing dataset' if ds is None else 'not a dataset:'} {name}")
        dtype, rest = want[name]
        if ds.dtype != dtype or ds.ndim != 1 + len(rest) or tuple(ds.shape[1:]) != rest:
            raise SessionFormatError(f"{where}/{name}: dtype {ds.dtype}, shape {ds.shape}; a {kind} session has "
                                     f"{dtype} of shape (T{''.join(f', {x}' for x in rest)})")
        if ds.chunks is not None and tuple(ds.chunks[1:]) != rest:
            raise SessionFormatError(f"{where}/{name}: chunks {ds.chunks} do not hold whole frames")
        lengths[name] = int(ds.shape[0])
    n_attr = g.attrs.get("n_frames", lengths[spec.dataset])
    if np.ndim(n_attr) != 0 or np.asarray(n_attr).dtype.kind not in "iu":
        raise SessionFormatError(f"{where}: attribute n_frames {n_attr!r} is not a count")
    if complete:
        n = int(n_attr)
        if len(set(lengths.values())) != 1 or n != lengths[spec.dataset]:
            raise SessionFormatError(f"{where}: per-frame datasets disagree in length {lengths} (n_frames={n})")
        return fshape, n
    n = min(lengths.values())
    if "committed" in g:
        c = g["committed"]
        if not isinstance(c, h5py.Dataset) or c.dtype.kind not in "iu" or c.shape != (1,):
            raise SessionFormatError(f"{where}/committed: not one count")
        n = max(min(n, int(c[0])), 0)
    for name in names:
        check_rows_stored(g[name], path, n)
    return fshape, n
