"""Checking a session file just written against the frames it was written from (docs/spec.md §6).

:func:`psmat.io.session._build.write_session_file` builds ``PATH.partial`` from the journal,
then, before the file replaces ``PATH`` and the journal is removed, reads it back: the file
is complete, each device holds the frame count the journal held, its stored CRC-32 tables
are the ones computed from the journal's frames as they were written, and every chunk read
back (HDF5 checks its Fletcher-32) has that CRC-32. Any difference is one RuntimeError naming
the file, the dataset and the frames, and the journal stays.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import NamedTuple

import h5py
import numpy as np
from numpy.typing import NDArray

from ._crc import CRC_NAME, chunk_crc
from ._events import verify_events


class Expected(NamedTuple):
    """What one device's group (``/`` or ``/streams/NAME``) must hold: frames, CRC-32 tables, counters."""

    n_frames: int
    tables: Mapping[str, NDArray[np.uint32]]  # dataset name -> CRC-32 per chunk, from the journal's frames
    counters: NDArray[np.int64]


def verify_written(path: Path, expected: Mapping[str, Expected],
                   events: Mapping[str, NDArray[np.uint32]] | None = None) -> None:
    """RuntimeError unless the file at ``path`` holds what ``expected`` (by group path) says.

    ``events``: the CRC-32 tables ``/events`` must hold (:func:`._events.expected_tables`;
    empty: the file has no events).

    Each chunk is read alone (rows of one chunk at a time), so memory stays one chunk's.
    """
    with h5py.File(path, "r") as f:
        if int(np.asarray(f.attrs.get("complete", 0))) != 1:
            raise RuntimeError(f"{path}: written file is not marked complete")
        for gname, want in expected.items():
            g = f[gname]
            where = g.name.rstrip("/")
            n = int(np.asarray(g.attrs.get("n_frames", -1)))
            if n != want.n_frames:
                raise RuntimeError(f"{path}: {where or '/'} holds {n} frames, the journal {want.n_frames}")
            counters = g["counters"][()]
            if not np.array_equal(counters, want.counters):
                raise RuntimeError(f"{path}: {where}/counters {counters.tolist()} differ from the journal's "
                                   f"{want.counters.tolist()}")
            for name, table in want.tables.items():
                _verify_dataset(path, g[name], g[CRC_NAME][name][()], table, want.n_frames)
        if events is not None:
            verify_events(f, path, dict(events))


def _verify_dataset(path: Path, ds: h5py.Dataset, stored: NDArray[np.uint32], table: NDArray[np.uint32],
                    n: int) -> None:
    if ds.shape[0] != n:
        raise RuntimeError(f"{path}: {ds.name} has {ds.shape[0]} rows, the journal {n} frames")
    if not np.array_equal(stored, table):
        raise RuntimeError(f"{path}: the CRC-32 table of {ds.name} differs from the journal's frames")
    c = int(ds.chunks[0]) if ds.chunks else max(n, 1)
    for i, a in enumerate(range(0, n, c)):
        b = min(a + c, n)
        try:
            rows = ds[a:b]  # HDF5 checks the chunk's Fletcher-32
        except OSError as e:
            raise RuntimeError(f"{path}: {ds.name} frames {a}..{b - 1} unreadable as written ({e})") from None
        if chunk_crc(ds.name, i, rows) != int(table[i]):
            raise RuntimeError(f"{path}: {ds.name} frames {a}..{b - 1} differ from the journal's")
