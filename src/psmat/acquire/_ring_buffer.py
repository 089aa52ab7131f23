"""Bounded, preallocated frame ring buffer shared by a reader thread and consumers.

The producer (the serial reader thread) never blocks: when the ring is full the oldest
frames are overwritten and counted in :attr:`FrameRing.dropped`. Consumers take frames
oldest first with :meth:`FrameRing.pop` (optionally waiting on a condition variable) or
peek at the newest with :meth:`FrameRing.latest`.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
from numpy.typing import DTypeLike, NDArray

from ..frames import FrameBatch

__all__ = ["FrameBatch", "FrameRing"]


class FrameRing:
    """Fixed-capacity ring of frames (thread-safe; the producer never blocks).

    Parameters
    ----------
    capacity : int
        Frames held (>= 1). Memory: ``capacity * (frame bytes + 25)`` bytes, allocated
        once.
    frame_shape : tuple of int
        Shape of one frame, e.g. ``(16, 16)``.
    dtype : dtype
        Frame dtype (uint16 counts or float32 degrees).

    Attributes
    ----------
    dropped : int
        Frames overwritten before anyone read them (overflow), cumulative.
    pushed : int
        Frames ever pushed.
    """

    def __init__(self, capacity: int, frame_shape: tuple[int, ...], dtype: DTypeLike) -> None:
        capacity = int(capacity)
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1 frame, got {capacity}")
        self.capacity = capacity
        self.frame_shape = tuple(int(x) for x in frame_shape)
        self.dtype = np.dtype(dtype)
        self._frames = np.zeros((capacity, *self.frame_shape), dtype=self.dtype)
        self._host = np.zeros(capacity, np.float64)
        self._valid = np.zeros(capacity, np.bool_)
        self._seq = np.zeros(capacity, np.int64)
        self._dev = np.zeros(capacity, np.int64)
        self._start = 0   # index of the oldest frame
        self._count = 0
        self.dropped = 0
        self.pushed = 0
        self._closed = False
        self.cond = threading.Condition(threading.Lock())

    def __len__(self) -> int:
        return self._count

    # -- producer ------------------------------------------------------------------------
    def push(self, frames: NDArray[Any], host_time_s: NDArray[np.float64] | float, valid: NDArray[np.bool_],
             seq: NDArray[np.int64], device_time_us: NDArray[np.int64]) -> int:
        """Append ``N`` frames (arrays with a leading axis N); overwrite the oldest if full.

        Returns
        -------
        int
            Frames dropped from the ring by this call.
        """
        n = int(valid.shape[0])
        if n == 0:
            return 0
        host = np.broadcast_to(np.asarray(host_time_s, np.float64), (n,))
        with self.cond:
            self.pushed += n
            cap = self.capacity
            lost = 0
            if n > cap:  # only the newest `cap` frames can be kept
                lost += n - cap
                frames, host, valid, seq, device_time_us = (a[n - cap:] for a in
                                                            (frames, host, valid, seq, device_time_us))
                n = cap
            over = self._count + n - cap
            if over > 0:
                lost += over
                self._start = (self._start + over) % cap
                self._count -= over
            end = (self._start + self._count) % cap
            first = min(n, cap - end)
            for dst, src in ((self._frames, frames), (self._host, host), (self._valid, valid),
                             (self._seq, seq), (self._dev, device_time_us)):
                dst[end:end + first] = src[:first]
                if first < n:
                    dst[:n - first] = src[first:]
            self._count += n
            self.dropped += lost
            self.cond.notify_all()
        return lost

    def wake(self) -> None:
        """Wake every consumer waiting in :meth:`wait_for` (e.g. the link was lost)."""
        with self.cond:
            self.cond.notify_all()

    # -- consumers -----------------------------------------------------------------------
    def _take(self, n: int, consume: bool, newest: bool = False) -> FrameBatch:
        n = max(0, min(n, self._count))
        first = self._start + (self._count - n if newest else 0)
        idx = (first + np.arange(n)) % self.capacity
        batch = FrameBatch(self._frames[idx], self._host[idx], self._valid[idx], self._seq[idx], self._dev[idx])
        if consume:
            self._start = (self._start + n) % self.capacity
            self._count -= n
        return batch

    def pop(self, n: int | None = None) -> FrameBatch:
        """Remove and return up to ``n`` of the oldest frames (all when None), without waiting."""
        with self.cond:
            return self._take(self._count if n is None else int(n), consume=True)

    def latest(self, n: int = 1) -> FrameBatch:
        """Copy of the newest ``n`` frames (fewer if fewer are held), oldest first; nothing consumed."""
        with self.cond:
            return self._take(int(n), consume=False, newest=True)

    def clear(self) -> int:
        """Discard everything held; return how many frames were discarded (not counted as dropped)."""
        with self.cond:
            n, self._count = self._count, 0
            return n

    def wait_for(self, n: int, timeout_s: float, stop: Any = None) -> int:
        """Wait until at least ``n`` frames are held, ``timeout_s`` s passed, or ``stop()`` is true.

        Parameters
        ----------
        n : int
            Frames wanted.
        timeout_s : float
            Longest wait (s); finite.
        stop : callable, optional
            Checked on every wake-up (after :meth:`wake`); a true result ends the wait.

        Returns
        -------
        int
            Frames held when the wait ended.
        """
        deadline = time.monotonic() + max(0.0, float(timeout_s))
        with self.cond:
            while self._count < n and not (stop is not None and stop()):
                left = deadline - time.monotonic()
                if left <= 0:
                    break
                self.cond.wait(left)
            return self._count
