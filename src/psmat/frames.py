"""Frames with their per-frame values: one type for everything that moves a block of frames
(the reader's ring buffer, the session writer, the journal, the loader)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import DTypeLike, NDArray

__all__ = ["FrameBatch"]


@dataclass(frozen=True, eq=False)
class FrameBatch:
    """``N`` consecutive frames with their timing, as arrays (oldest first).

    Attributes
    ----------
    frames : ndarray, shape (N, *frame_shape)
        uint16 counts (PSM, material DAQ) or float32 Euler angles in degrees (IMU); zeros
        (counts) or NaN (angles) in invalid rows.
    host_time_s : ndarray of float64, shape (N,)
        Host arrival time of the serial chunk that completed the frame (s since the Unix
        epoch, monotonic-corrected; frames of one chunk share it).
    valid : ndarray of bool, shape (N,)
        False for a frame that failed its checksum/CRC (or a malformed DAQ line).
    seq : ndarray of int64, shape (N,)
        Device sequence number (v2); -1 when unknown (v1, DAQ, invalid rows).
    device_time_us : ndarray of int64, shape (N,)
        Device clock at the start of the scan, unwrapped (µs, v2); -1 when unknown.
    """

    frames: NDArray[Any]
    host_time_s: NDArray[np.float64]
    valid: NDArray[np.bool_]
    seq: NDArray[np.int64]
    device_time_us: NDArray[np.int64]

    def __len__(self) -> int:
        return int(self.valid.shape[0])

    @classmethod
    def empty(cls, frame_shape: tuple[int, ...], dtype: DTypeLike) -> FrameBatch:
        """A batch of zero frames."""
        return cls(np.empty((0, *frame_shape), dtype=dtype), np.empty(0, np.float64), np.empty(0, np.bool_),
                   np.empty(0, np.int64), np.empty(0, np.int64))
