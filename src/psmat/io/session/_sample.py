"""A few frames from the middle of a session's file, for estimates (how much work processing it is),
and the host times its recording spans, for checks made before it is processed.

One chunk of the frame dataset is read (HDF5 checks its Fletcher-32 as it reads); nothing else of
the file's checks runs, so the frames serve an estimate only, never a result: a session is read,
and checked, whole by :func:`psmat.io.load_session` where it is processed.
"""

from __future__ import annotations

import os

import h5py
import numpy as np
from numpy.typing import NDArray

from ._layout import KINDS, attr_str, utc_offset_value

__all__ = ["sample_frames", "host_time_span"]


def sample_frames(path: str | os.PathLike[str], count: int = 8) -> tuple[int, NDArray[np.generic]] | None:
    """(frames in the file, up to ``count`` consecutive frames from the start of its middle chunk),
    or None when the file cannot give them (missing, not a session, no frames, a damaged chunk)."""
    try:
        with h5py.File(path, "r") as f:
            kind = attr_str(f.attrs["kind"])
            ds = f[KINDS[kind].dataset]
            n = int(ds.shape[0])
            if n == 0:
                return None
            chunk = int(ds.chunks[0]) if ds.chunks else n
            start = (n // 2) // chunk * chunk
            return n, np.asarray(ds[start:min(n, start + count)])
    except (OSError, KeyError, ValueError, TypeError):
        return None


def host_time_span(path: str | os.PathLike[str]) -> tuple[float, float] | None:
    """(first, last) host time (s) of a session's frames, from its file's first and last chunks of
    ``host_time_s``; None when the file cannot give them (missing, not a session, no frame with a
    time in those chunks, a damaged chunk)."""
    try:
        with h5py.File(path, "r") as f:
            ds = f["host_time_s"]
            n = int(ds.shape[0])
            chunk = int(ds.chunks[0]) if ds.chunks else n
            if n == 0:
                return None
            head = np.asarray(ds[:min(n, chunk)], np.float64)
            tail = np.asarray(ds[max(0, n - chunk):n], np.float64)
    except (OSError, KeyError, ValueError, TypeError):
        return None
    head, tail = head[np.isfinite(head)], tail[np.isfinite(tail)]
    if head.size == 0 or tail.size == 0:
        return None
    return float(head[0]), float(tail[-1])


def utc_offset_of(path: str | os.PathLike[str]) -> int | None:
    """The recording computer's offset from UTC stored in a session file (s east of UTC,
    ``Session.utc_offset_s``), read without loading the session; None when the file has none (written
    before psmat stored it), holds no valid one, or cannot be read."""
    try:
        with h5py.File(path, "r") as f:
            v = f.attrs.get("utc_offset_s")
    except (OSError, KeyError, ValueError, TypeError):
        return None
    return None if v is None else utc_offset_value(v)
