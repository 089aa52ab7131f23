"""What the live acquisition sources share (docs/spec.md §5): a reader thread puts each batch of
frames into a ring buffer that :meth:`read` and :meth:`latest` take from and, while a session writer
is attached (:meth:`record_to`), into the writer too, so that an overflowing buffer never loses
recorded frames. :class:`~psmat.acquire.Device` (a mat or DAQ on a serial port or socket) and
:class:`~psmat.acquire.LslDevice` (an LSL inlet) are such sources.
"""

from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from typing import Any, Self

import numpy as np
from numpy.typing import NDArray

from .._atomic import no_space
from ._errors import DeviceDisconnected
from ._ring_buffer import FrameBatch, FrameRing
from ._stats import DeviceStats


class BufferedSource(ABC):
    """Ring buffer, session recorder and context manager of a live source.

    A subclass calls :meth:`_init_buffer` in its constructor, sets ``port``, ``kind``,
    ``read_timeout_s``, ``_gone`` (lost for good), ``_closed``, ``_started`` and ``_last_error``,
    provides ``stats``, ``start()`` and ``close()`` (which calls :meth:`stop_recording`), and hands
    every batch its reader thread decodes to :meth:`_deliver`.
    """

    port: str
    kind: str
    shape: tuple[int, ...]
    dtype: np.dtype[Any]
    read_timeout_s: float
    _gone: bool
    _closed: bool
    _started: bool
    _last_error: str | None
    #: what :class:`DeviceDisconnected` calls a source that is gone
    _lost_what = "device"

    def _init_buffer(self, buffer_frames: int) -> None:
        self._ring = FrameRing(buffer_frames, self.shape, self.dtype)
        self._recorder: Any = None
        self._recorder_lock = threading.Lock()
        self._recording_error: str | None = None

    @property
    @abstractmethod
    def stats(self) -> DeviceStats:
        """The source's counters (``stats.last_error`` also reports a writer that failed)."""

    @abstractmethod
    def start(self) -> None:
        """Start buffering (and recording) frames."""

    @abstractmethod
    def close(self) -> None:
        """Stop, end the reader thread, release the source and :meth:`stop_recording` (idempotent)."""

    # -- reading -------------------------------------------------------------------------
    def read(self, n: int | None = None, timeout_s: float | None = None) -> FrameBatch:
        """Take frames from the buffer, oldest first.

        Parameters
        ----------
        n : int, optional
            Frames wanted. None: everything buffered now (waiting up to ``timeout_s`` s for at
            least one frame when ``timeout_s`` is given).
        timeout_s : float, optional
            Longest wait for ``n`` frames (s); None means :attr:`read_timeout_s`. Never
            blocks forever: on timeout, or when the link is lost, returns what it has.

        Returns
        -------
        FrameBatch
            Up to ``n`` frames (possibly none).

        Raises
        ------
        DeviceDisconnected
            The source is gone (a port that vanished and is not coming back, an LSL stream
            whose inlet failed) and the buffer is empty.
        """
        if n is not None and n < 0:
            raise ValueError(f"n must be >= 0, got {n}")
        want = 1 if n is None else n
        if want > 0 and (n is not None or timeout_s is not None):
            wait = self.read_timeout_s if timeout_s is None else float(timeout_s)
            self._ring.wait_for(want, wait, stop=lambda: self._gone or self._closed)
        batch = self._ring.pop(n)
        if len(batch) == 0 and want > 0 and self._gone:
            raise DeviceDisconnected(self.port, self._last_error, what=self._lost_what)
        return batch

    def latest(self, n: int = 1) -> FrameBatch:
        """The newest ``n`` buffered frames (oldest first) without consuming them."""
        return self._ring.latest(n)

    # -- recording -----------------------------------------------------------------------
    def record_to(self, writer: Any) -> None:
        """Append every buffered batch to a :class:`psmat.io.SessionWriter` (or a session stream) too.

        The writer receives frames from the reader thread as they arrive (while started),
        independently of :meth:`read`, so ring-buffer overflow never loses recorded frames.
        :meth:`stop_recording` (called by ``close``) stores the final counters with
        ``set_counters``; closing the writer stays the caller's job. A writer error detaches it
        and is reported in ``stats.last_error``.
        """
        from ._recording import SessionRecorder

        self.stop_recording()
        with self._recorder_lock:
            self._recorder = SessionRecorder(writer, self.kind, self.shape)

    @property
    def recording_error(self) -> str | None:
        """Why the session writer of :meth:`record_to` was detached by an error (the disk full, ...),
        or None: acquisition goes on without it, and a recorder must stop and say so (``psmat record``)."""
        return self._recording_error

    def stop_recording(self) -> None:
        """Detach the session writer (storing the final counters); no-op without one."""
        with self._recorder_lock:
            rec, self._recorder = self._recorder, None
        if rec is not None:
            try:
                rec.finish(self.stats)
            except Exception as exc:  # noqa: BLE001 - the writer may already be closed
                self._last_error = f"recording: {exc}"

    def _deliver(self, frames: NDArray[Any], host: NDArray[np.float64], valid: NDArray[np.bool_],
                 seq: NDArray[np.int64], dev: NDArray[np.int64]) -> None:
        """One batch from the reader thread: to the recorder (if any), then to the buffer."""
        with self._recorder_lock:
            rec = self._recorder
            if rec is not None:
                try:
                    rec.append(frames, host, valid, seq, dev)
                except Exception as exc:  # noqa: BLE001 - a recording problem must not stop acquisition
                    self._recorder = None
                    self._last_error = f"recording stopped: {type(exc).__name__}: {exc}"
                    self._recording_error = no_space(exc) or f"{type(exc).__name__}: {' '.join(str(exc).split())}"
        self._ring.push(frames, host, valid, seq, dev)

    # -- context manager -----------------------------------------------------------------
    def __enter__(self) -> Self:
        if not self._started:
            self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
