"""Thin adapter from a :class:`~psmat.acquire.Device` to a :class:`psmat.io.SessionWriter`."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..io import RowTally

__all__ = ["SessionRecorder"]


class SessionRecorder:
    """Forward decoded batches to a session writer; store the device's counters at the end.

    Parameters
    ----------
    writer : psmat.io.SessionWriter
        Any object with ``append(frames, host_time_s, valid, seq, device_time_us)`` and
        ``set_counters(**counters)``; it stays owned (and closed) by the caller.
    kind, shape : str, tuple of int, optional
        The device's; checked against ``writer.kind`` / ``writer.frame_shape`` when the
        writer has them.

    Notes
    -----
    Counter mapping (:data:`psmat.io.COUNTER_NAMES`): ``bad_frames`` = invalid rows and
    ``dropped_frames`` = frames lost on the wire (v2 ``seq`` gaps no row stands for), both
    counted over the rows this recorder appended (:class:`psmat.io.RowTally`, the definition
    ``psmat info`` applies to the file), not since the device was opened; ``bytes_discarded``
    = skipped bytes (the device's count); ``resyncs`` is not measured and left as is.
    """

    def __init__(self, writer: Any, kind: str | None = None, shape: tuple[int, ...] | None = None) -> None:
        wkind = getattr(writer, "kind", None)
        wshape = getattr(writer, "frame_shape", None)
        if kind is not None and wkind is not None and wkind != kind:
            raise ValueError(f"the session writer records {wkind!r} frames, the device is {kind!r}")
        if shape is not None and wshape is not None and tuple(wshape) != tuple(shape):
            raise ValueError(f"the session writer expects frames of shape {tuple(wshape)}, the device sends {shape}")
        self.writer = writer
        self.tally = RowTally()

    def append(self, frames: NDArray[Any], host_time_s: NDArray[np.float64], valid: NDArray[np.bool_],
               seq: NDArray[np.int64], device_time_us: NDArray[np.int64]) -> None:
        """Append one batch (called from the reader thread)."""
        self.writer.append(frames, host_time_s, valid, seq, device_time_us)
        self.tally.add(valid, seq)  # only what the writer took

    def finish(self, stats: Any) -> None:
        """Store the final counters from a :class:`~psmat.acquire.DeviceStats`."""
        rows = self.tally.counts
        self.writer.set_counters(dropped_frames=rows.lost or 0, bad_frames=rows.invalid,
                                 bytes_discarded=stats.skipped_bytes)
