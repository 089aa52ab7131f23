"""Writing a complete session file (docs/spec.md §6): the HDF5 layout of
:mod:`._layout` filled from a device's frame blocks, metadata first and frames last, read
back and checked before it replaces anything (:mod:`._verify`).

:func:`write_session_file` is what :class:`psmat.io.SessionWriter` calls when it closes and
:func:`psmat.io.repair_session` when it finishes a journal; :func:`write_product` adds a product.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from ... import _atomic
from ..._atomic import fsync_dir
from ...frames import FrameBatch

from ._crc import CRC_NAME, ChunkCrcs, chunk_crc
from ._events import EVENTS_CHUNK, Event, create_events, expected_tables, sort_events
from ._layout import (COUNTER_NAMES, FORMAT_NAME, FORMAT_VERSION, Header, PER_FRAME, PER_FRAME_SPEC, Product, STREAMS_FORMAT_VERSION, StreamBlocks, check_stream_name, partial_path, psmat_version, put_attr, set_flat_attrs, to_json, utc_now)
from ._verify import Expected, verify_written


def write_product(f: h5py.File, name: str, array: Any, params: Mapping[str, Any], unit: str) -> None:
    """Create (or replace) ``/products/NAME``, Fletcher-32 checksummed when it has elements."""
    _write_data(*_create_product(f, name, array, params, unit))


def _write_data(ds: h5py.Dataset, arr: NDArray[Any]) -> None:
    if arr.size:
        ds[...] = arr


def _create_product(f: h5py.File, name: str, array: Any, params: Mapping[str, Any],
                    unit: str) -> tuple[h5py.Dataset, NDArray[Any]]:
    """``/products/NAME`` with its attributes, its data not written yet (:func:`_write_data`): the dataset, the data."""
    g = f.require_group("products")
    if name in g:
        del g[name]
    arr = np.asarray(array)
    if arr.dtype.kind not in "biuf":
        raise TypeError(f"product {name!r} must be a numeric array, got dtype {arr.dtype}")
    if arr.dtype.kind == "b":
        arr = arr.astype(np.uint8)
    chunked = arr.ndim > 0 and arr.size > 0
    ds = g.create_dataset(name, shape=arr.shape, dtype=arr.dtype, chunks=True if chunked else None,
                          fletcher32=chunked)
    put_attr(ds, CRC_NAME, np.uint32(chunk_crc(ds.name, 0, arr)))  # what Fletcher-32 misses (._crc)
    put_attr(ds, "unit", str(unit))
    pj = to_json(dict(params))
    put_attr(ds, "params_json", pj)
    put_attr(ds, "created_utc", utc_now())
    set_flat_attrs(ds, json.loads(pj), skip=("unit", "params_json", "created_utc"))
    return ds, arr


def _create_device(g: h5py.Group, h: Header, n: int,
                   counters: Mapping[str, int]) -> list[tuple[h5py.Dataset, NDArray[Any]]]:
    """A device's part of the layout in ``g`` (``/`` or ``/streams/NAME``), no data written yet.

    Kind, the frame and per-frame datasets of ``n`` frames, their CRC-32 tables and the
    counters. Returns the data to write before the frames (:func:`_write_data`): the tables
    (zeros, filled in place once the frames are written) and the counters.
    """
    spec = h.spec
    put_attr(g, "kind", h.kind)
    put_attr(g, "frame_shape", np.asarray(h.frame_shape, dtype=np.int64))
    put_attr(g, "frame_dataset", spec.dataset)
    put_attr(g, "n_frames", np.int64(n))
    c = h.chunk_frames
    # docs/spec.md §6: every frame dataset carries Fletcher-32 checksums, one per chunk of c frames
    d = g.create_dataset(spec.dataset, shape=(n, *h.frame_shape), maxshape=(None, *h.frame_shape),
                         dtype=spec.dtype, chunks=(c, *h.frame_shape), fletcher32=True)
    put_attr(d, "unit", spec.unit)
    put_attr(d, "axes", spec.axes)
    names = [spec.dataset]
    for name, (dt, unit, desc, _fill) in PER_FRAME_SPEC.items():
        ds = g.create_dataset(name, shape=(n,), maxshape=(None,), dtype=dt, chunks=(c,), fletcher32=True)
        put_attr(ds, "unit", unit)
        put_attr(ds, "description", desc)
        names.append(name)
    # docs/spec.md §6: a CRC-32 per chunk, bound to its dataset and position (._crc); no filter, so a
    # damaged entry costs its own chunk's frames only
    cg = g.create_group(CRC_NAME)
    data: list[tuple[h5py.Dataset, NDArray[Any]]] = []
    for name in names:
        t = cg.create_dataset(name, shape=(-(-n // c),), dtype="<u4")
        data.append((t, np.zeros(t.shape, t.dtype)))
        put_attr(t, "unit", "1")
        put_attr(t, "chunk_frames", np.int64(c))
        put_attr(t, "description", f"CRC-32 of each chunk of {g[name].name}: zlib.crc32 of the path, NUL, "
                                   "the chunk index (int64 LE), the chunk's rows (LE)")
    values = np.array([int(counters.get(k, 0)) for k in COUNTER_NAMES], np.int64)
    k = g.create_dataset("counters", shape=values.shape, dtype=values.dtype, chunks=(len(COUNTER_NAMES),),
                         fletcher32=True)
    put_attr(k, CRC_NAME, np.uint32(chunk_crc(k.name, 0, values)))
    put_attr(k, "unit", "1")
    put_attr(k, "names", list(COUNTER_NAMES))
    return [*data, (k, values)]


def _create_dict_groups(g: h5py.Group, groups: Mapping[str, dict[str, Any] | None]) -> None:
    for gname, d_ in groups.items():
        if d_ is None:
            continue
        sub = g.create_group(gname)
        put_attr(sub, "json", to_json(d_))
        set_flat_attrs(sub, d_)


def _whole_chunks(blocks: Iterable[FrameBatch], c: int) -> Iterator[FrameBatch]:
    """``blocks`` regrouped into batches of ``c`` frames (the last one shorter), one chunk each."""
    pending: list[FrameBatch] = []
    have = 0
    for b in blocks:
        if len(b) == 0:
            continue
        pending.append(b)
        have += len(b)
        if have < c:
            continue
        cat = _concat(pending)
        full = have - have % c
        for a in range(0, full, c):
            yield _rows(cat, a, a + c)
        pending = [_rows(cat, full, have)] if have > full else []
        have -= full
    if have:
        yield _concat(pending)


def _concat(bs: list[FrameBatch]) -> FrameBatch:
    if len(bs) == 1:
        return bs[0]
    return FrameBatch(*(np.concatenate([getattr(b, k) for b in bs]) for k in FrameBatch.__dataclass_fields__))


def _rows(b: FrameBatch, a: int, z: int) -> FrameBatch:
    return FrameBatch(*(getattr(b, k)[a:z] for k in FrameBatch.__dataclass_fields__))


def _fill_device(g: h5py.Group, h: Header, n: int, blocks: Iterable[FrameBatch]) -> dict[str, NDArray[np.uint32]]:
    """Write ``blocks`` (``n`` frames) into ``g``'s datasets one chunk at a time; return and store their CRC-32 tables.

    Chunk ``i`` of every dataset is written before chunk ``i + 1`` of any (no chunk cache), so
    the chunks lie in the file in frame order: a file cut short loses its last frames.
    """
    dname = h.spec.dataset
    names = (dname, *PER_FRAME)
    crcs = {name: ChunkCrcs(g[name].name, h.chunk_frames, g[name].dtype) for name in names}
    k = 0
    for b in _whole_chunks(blocks, h.chunk_frames):
        m = len(b)
        if k + m > n:
            raise ValueError(f"{g.name}: more frames than the {n} expected")
        cols = {dname: b.frames, "host_time_s": b.host_time_s, "valid": b.valid.astype(np.uint8),
                "seq": b.seq, "device_time_us": b.device_time_us}
        for name in names:
            g[name][k : k + m] = cols[name]
            crcs[name].feed(cols[name])
        k += m
    if k != n:
        raise ValueError(f"{g.name}: {k} frames written, {n} expected")
    tables = {name: c.table() for name, c in crcs.items()}
    for name, t in tables.items():
        if t.size:
            g[CRC_NAME][name][...] = t  # in place: the table's storage was allocated before the frames'
    return tables


#: bytes of HDF5 metadata reserved at the start of a file: a base (superblock, root group), per device
#: (its groups, datasets' headers and attributes), per dictionary entry (plus three per JSON byte), and
#: per chunk of each of a device's five per-frame datasets (its entry in the chunk index, an extensible
#: array whose blocks double: about 21 bytes measured, at most 20 bytes an entry twice over)
_META_BASE, _META_DEVICE, _META_ENTRY, _META_CHUNK = 4096, 8192, 128, 48


def meta_block_size(devices: Iterable[tuple[Header, int]], extra: Iterable[Mapping[str, Any] | None],
                    n_events: int = 0) -> int:
    """An upper bound (bytes, a multiple of 4096) of the HDF5 metadata of a session file.

    Parameters
    ----------
    devices : iterable of (Header, int)
        Each device of the file with its frame count.
    extra : iterable of dict or None
        The other dictionaries stored as attributes (calibration, metadata, profile, products'
        parameters, extra root attributes).
    n_events : int
        The events stored (``/events``: a group, two datasets and their CRC-32 tables).

    The file is written with this metadata block size: every piece of metadata is allocated
    from one block at the start of the file, so it precedes every frame.
    """

    def size(d: Mapping[str, Any] | None) -> int:
        return 0 if d is None else 3 * len(to_json(d).encode("utf-8")) + _META_ENTRY * len(d)

    total = _META_BASE + sum(size(d) for d in extra)
    if n_events:
        total += _META_DEVICE + 2 * _META_CHUNK * -(-n_events // EVENTS_CHUNK)
    for h, n in devices:
        total += _META_DEVICE + size(h.device) + 5 * _META_CHUNK * -(-n // h.chunk_frames)
    return -(-total // 4096) * 4096


def write_session_file(
    path: Path,
    header: Header,
    blocks: Iterable[FrameBatch],
    counters: Mapping[str, int],
    *,
    n_frames: int | None = None,
    products: Mapping[str, Product] | None = None,
    attrs: Mapping[str, str] | None = None,
    streams: Mapping[str, StreamBlocks] | None = None,
    events: Sequence[Event] = (),
) -> int:
    """Write a complete session file at ``path``, atomically; return the number of frames of the root device.

    The file is built as ``PATH.partial``, marked complete, fsync'd, read back and checked
    against the frames it was written from (:func:`._verify.verify_written`: frame
    counts, every chunk's CRC-32), then renamed over ``path``: a session file that exists is
    always a complete one. ``n_frames`` is the number of frames ``blocks`` yields (None:
    ``blocks`` is gathered to count them); ``attrs`` are extra string attributes of ``/``
    (e.g. ``repaired_utc``); ``streams`` the other devices, by stream name (group
    ``/streams/NAME``); ``events`` the recording's (host time s, label) markers (``/events``,
    sorted by time, checked like the frames).

    All of the file's HDF5 metadata precedes its data, and the frames' chunks lie in frame
    order after the CRC-32 tables, counters and products: a copy of the file cut short loses
    its trailing chunks only (:mod:`._truncated`).

    Raises
    ------
    ValueError
        ``blocks`` yields another number of frames than ``n_frames``.
    RuntimeError
        The file read back differs from the frames it was written from.
    """
    if n_frames is None:
        blocks = list(blocks)
        n_frames = sum(len(b) for b in blocks)
    devices = {"/": StreamBlocks(header, blocks, counters, int(n_frames))}
    for name, st in (streams or {}).items():
        if st.n_frames is None:
            st = st._replace(blocks=list(st.blocks))
            st = st._replace(n_frames=sum(len(b) for b in st.blocks))
        devices[f"/streams/{check_stream_name(name)}"] = st
    events = sort_events(events)
    tmp = partial_path(path)
    tmp.unlink(missing_ok=True)
    try:
        expected = _write_file(tmp, devices, products or {}, attrs or {}, events)
        _atomic.fsync_file(tmp)  # looked up when called: a test stands a failing disk in for it
        verify_written(tmp, expected, events=expected_tables(events))
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, path)
    fsync_dir(path.parent)
    return int(n_frames)


def _write_file(tmp: Path, devices: Mapping[str, StreamBlocks], products: Mapping[str, Product],
                attrs: Mapping[str, str], events: Sequence[Event] = ()) -> dict[str, Expected]:
    """The file in three passes, so that every piece of metadata precedes every frame.

    1. every group, dataset and attribute, no data (all in the metadata block at the start);
    2. the data that is not frames: CRC-32 tables (zeros for now), counters, events, products;
    3. the frames, chunk by chunk in frame order, then the CRC-32 tables (in place) and
       ``complete`` (in place: the same type).
    """
    header = devices["/"].header
    mbs = meta_block_size([(st.header, int(st.n_frames or 0)) for st in devices.values()],
                          [header.calibration, header.metadata, header.profile, dict(attrs),
                           *(p.params for p in products.values())], n_events=len(events))
    # latest: checksums on every metadata object too; no chunk cache: each chunk goes to the file when written
    with h5py.File(tmp, "w", libver="latest", meta_block_size=mbs, rdcc_nbytes=0) as f:
        put_attr(f, "format", FORMAT_NAME)
        put_attr(f, "format_version", STREAMS_FORMAT_VERSION if len(devices) > 1 else FORMAT_VERSION)
        put_attr(f, "created_utc", header.created_utc)
        if header.utc_offset_s is not None:  # (docs/spec.md §6: wall-clock times of the recording computer)
            f.attrs["utc_offset_s"] = np.int32(header.utc_offset_s)
        put_attr(f, "psmat_version", psmat_version())
        put_attr(f, "complete", np.uint8(0))
        put_attr(f, "closed_utc", utc_now())
        for key, val in attrs.items():
            put_attr(f, key, val)
        _create_dict_groups(f, {"device": header.device, "calibration": header.calibration,
                                "metadata": header.metadata, "profile": header.profile})
        made_events = create_events(f, events)
        f.create_group("products")
        data = {}
        for gname, st in devices.items():
            if gname == "/":
                g = f
            else:
                g = f.require_group("streams").create_group(gname.rsplit("/", 1)[1])
                _create_dict_groups(g, {"device": st.header.device})
            data[gname] = _create_device(g, st.header, int(st.n_frames or 0), st.counters)
        made = [_create_product(f, name, p.data, p.params, p.unit) for name, p in products.items()]
        for ds, arr in [*(x for d in data.values() for x in d), *made_events, *made]:
            _write_data(ds, arr)
        expected = {gname: Expected(int(st.n_frames or 0),
                                    _fill_device(f[gname], st.header, int(st.n_frames or 0), st.blocks),
                                    data[gname][-1][1])
                    for gname, st in devices.items()}
        f.attrs.modify("complete", np.uint8(1))
    return expected


