"""Live crosstalk removal: frames in as they arrive, crosstalk-free frames out in order.

The reference design is the thesis' C thread pool (Fig. 2.10): a producer queues frames,
worker threads solve them, a consumer takes them in order. Each frame warm-starts from the
newest solution available and reuses its worker's preconditioner, so a live recording
costs a few Krylov iterations per frame, not cold solves.

:meth:`Stream.ready` never waits, so frames that arrive faster than they are solved are
still queued when the input ends: :meth:`Stream.drain` waits for them. Leaving the ``with``
block does not wait; it warns when frames were pushed and never popped.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import threading
import warnings

import numpy as np

from .. import _core
from ._validate import as_frames, check_dense_size
from ._info import SolveInfo
from ._run import make_options

__all__ = ["Stream"]


class Stream:
    """In-order, multi-threaded IECM on a live stream of (R, C) frames.

    Parameters
    ----------
    shape : (int, int)
        Array shape (R, C).
    method : str
        As :func:`psmat.iecm.solve`.
    threads : int
        Worker threads (1 keeps every frame warm-started from its predecessor).
    max_pending : int
        Frames queued or unread before :meth:`push` blocks (back-pressure, bounded memory).
    **options
        ``rtol``, ``max_iter``, ``beta``, ``g_floor``, ``reuse_factorization``, ``fallback`` as
        in solve.

    Examples
    --------
    >>> with Stream((16, 16)) as s:               # doctest: +SKIP
    ...     for G in frames_from_mat():
    ...         s.push(G)
    ...         for seq, g, info in s.ready():   # solved so far, without waiting
    ...             show(g)
    ...     for seq, g, info in s.drain():       # the rest, waiting for each
    ...         show(g)
    """

    def __init__(self, shape: tuple[int, int], method: str = "newton", *, threads: int = 1,
                 max_pending: int = 256, **options):
        rows, cols = (int(v) for v in shape)
        if rows < 2 or cols < 2:
            raise ValueError(f"shape must be at least (2, 2), got {shape}")
        if threads < 1 or max_pending < 1:
            raise ValueError("threads and max_pending must be >= 1")
        self.shape = (rows, cols)
        self.method = method
        self.max_pending = int(max_pending)
        opts = make_options(method, **options)
        check_dense_size(self.shape, method, threads=int(threads), fallback=bool(opts.fallback))
        self._g_floor = float(opts.g_floor)
        # seq -> smallest measured G, for solve's floor statuses; a consumer thread may pop a
        # frame before its producer has filed it, so pop waits on the condition for the entry
        self._G_min: dict[int, float] = {}
        self._filed = threading.Condition()
        self._s = _core.iecm.StreamSolver(rows, cols, opts, int(threads), self.max_pending)
        self._closed = False

    def push(self, G, timeout_s: float | None = None) -> int:
        """Queue one frame of equivalent conductances (S); returns its sequence number.

        When ``max_pending`` frames are pushed but not yet popped, waits for a consumer (in
        another thread) to pop one - at most ``timeout_s`` seconds (None: no limit), then
        raises TimeoutError. A single thread that both pushes and pops should use
        :meth:`process`, which pops before pushing into a full stream.
        """
        if self._closed:
            raise RuntimeError("the stream is closed")
        frames, single = as_frames(G, "G", allow_zero=False, max_ndim=2, measured=True)
        if frames.shape[1:] != self.shape:
            raise ValueError(f"frame shape {frames.shape[1:]} does not match the stream's {self.shape}")
        seq = self._s.push(frames[0], -1.0 if timeout_s is None else float(timeout_s))
        if seq is None:
            raise TimeoutError(
                f"the stream stayed full ({self.max_pending} frames unread) for {timeout_s} s: pop() results"
            )
        with self._filed:
            self._G_min[int(seq)] = float(frames[0].min())
            self._filed.notify_all()
        return int(seq)

    def pop(self, timeout_s: float | None = None):
        """Next frame in order as ``(seq, g, info)``; None if none ready within ``timeout_s`` s.

        ``timeout_s=None`` waits until the next frame is solved (or the stream is closed and
        drained).
        """
        r = self._s.pop(-1.0 if timeout_s is None else float(timeout_s))
        if r is None:
            return None
        seq, g, rep = r
        info = SolveInfo.from_reports([rep], self.method, single=True)
        with self._filed:
            self._filed.wait_for(lambda: int(seq) in self._G_min)
            G_min = self._G_min.pop(int(seq))
        info.flag_floor(np.array([G_min]), g[None], self._g_floor)  # as solve: the status, no warning per frame
        return int(seq), g, info

    def ready(self) -> Iterator[tuple[int, np.ndarray, SolveInfo]]:
        """Frames already solved, in order, without waiting."""
        while (r := self.pop(0.0)) is not None:
            yield r

    @property
    def pending(self) -> int:
        """Frames pushed and not yet popped."""
        return int(self._s.pending)

    def close(self) -> None:
        """Stop accepting frames; queued ones are still solved and can be popped."""
        self._closed = True
        self._s.close()

    def drain(self) -> Iterator[tuple[int, np.ndarray, SolveInfo]]:
        """Close and yield every remaining frame in order."""
        self.close()
        while (r := self.pop(None)) is not None:
            yield r

    def process(self, frames: Iterable, *, close: bool = True) -> Iterator[tuple[int, np.ndarray, SolveInfo]]:
        """Push every frame of an iterable, yielding results in order as they become ready.

        With ``close`` (default) the stream is then closed (:meth:`drain`); without, the last
        frames are waited for and the stream stays open, warm, for the next chunk of a stream
        (as :class:`psmat.process.Processor` pushes it).
        """
        for G in frames:
            while self.pending >= self.max_pending:  # full: the consumer is this thread
                r = self.pop(None)
                if r is not None:
                    yield r
            self.push(G)
            yield from self.ready()
        if close:
            yield from self.drain()
            return
        while self.pending:
            r = self.pop(None)
            if r is not None:
                yield r

    def __enter__(self) -> "Stream":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        unread = self.pending
        self.close()
        if exc_type is None and unread:
            warnings.warn(f"Stream: {unread} frames pushed and never popped at the end of the with block; "
                          "drain() returns them", RuntimeWarning, stacklevel=2)

