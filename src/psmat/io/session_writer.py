"""Writing a session: frames go to the journal as they arrive, to the HDF5 file when it closes."""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..frames import FrameBatch

from . import session_journal as jr
from .session_layout import (
    COUNTER_NAMES,
    KINDS,
    Header,
    as_dict,
    fsync_dir,
    journal_path,
    partial_path,
    utc_now,
    write_session_file,
)


class SessionWriter:
    """Write a session to ``path`` with a crash-safety journal; use as a context manager.

    While recording, every appended frame is written to the journal ``PATH.journal`` before
    :meth:`append` returns; :meth:`close` turns the journal into the HDF5 file ``path``
    (which appears only then, complete) and removes the journal. A writer that is killed
    leaves the journal, which :func:`psmat.io.load_session` reads (SPEC §6).

    Parameters
    ----------
    path : str or Path
        The ``.h5`` file to create. An existing file (or journal) is an error unless
        ``overwrite=True``.
    shape : tuple of int
        Frame shape: ``(R, C)`` for ``kind="psm"``, ``(5, 3)`` for ``"imu"`` (sensors ×
        heading/roll/pitch), ``(10,)`` (or ``10``) for ``"daq"``.
    device : dict
        Device description (serial, r_o, v_ref, bits, fw, protocol, rate, …; e.g. the
        parsed IDENTIFY reply). ``shape`` and ``kind`` are added if missing.
    calibration : dict or object with ``to_dict()``, optional
        The calibration used (e.g. :class:`psmat.Calibration`).
    metadata : dict, optional
        Subject/trial metadata (subject id, trial, condition, operator, notes, …).
    kind : {"psm", "imu", "daq"}
    chunk_frames : int
        Frames per HDF5 chunk along time: the unit that carries one checksum, so the most
        frames one damaged byte of the finished file can cost.
    flush_interval_s, flush_frames : float, int
        The journal is fsync'd (made safe from a power cut, not only from the process
        being killed) when either this much time (s) has passed since the last sync or this
        many frames are unsynced.
    background : bool
        True (default): syncing happens on a writer thread, so :meth:`append` only encodes
        the batch and writes its journal records — safe to call from a serial reader thread
        at 165 Hz. False: :meth:`append` syncs inline when due.
    overwrite : bool

    Thread safety: :meth:`append`, :meth:`set_counters` and :meth:`flush` may be called from
    any thread (calls are serialised internally); frames are stored in call order.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        shape: int | tuple[int, ...],
        device: Mapping[str, Any],
        calibration: Any = None,
        metadata: Mapping[str, Any] | None = None,
        kind: str = "psm",
        chunk_frames: int = 256,
        *,
        flush_interval_s: float = 0.5,
        flush_frames: int = 512,
        background: bool = True,
        overwrite: bool = False,
    ) -> None:
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {sorted(KINDS)}, got {kind!r}")
        fshape = (int(shape),) if isinstance(shape, (int, np.integer)) else tuple(int(x) for x in shape)
        if kind == "psm" and len(fshape) != 2:
            raise ValueError(f"a psm frame shape is (R, C), got {fshape}")
        if kind == "imu" and (len(fshape) != 2 or fshape[1] != 3):
            raise ValueError(f"an imu frame shape is (n_sensors, 3), got {fshape}")
        if kind == "daq" and len(fshape) != 1:
            raise ValueError(f"a daq frame shape is (n_sensors,), got {fshape}")
        if any(x < 1 for x in fshape):
            raise ValueError(f"frame shape must be positive, got {fshape}")
        if chunk_frames < 1 or flush_frames < 1 or not flush_interval_s > 0:
            raise ValueError("chunk_frames and flush_frames must be >= 1 and flush_interval_s > 0")
        self.path = Path(path)
        self.jpath = journal_path(self.path)
        for p in (self.path, self.jpath):
            if p.exists() and not overwrite:
                raise FileExistsError(f"{p} exists (pass overwrite=True to replace it)")
        dev = as_dict(device, "device") or {}
        dev.setdefault("kind", kind)
        dev.setdefault("shape", list(fshape))
        self.header = Header(kind=kind, frame_shape=fshape, device=dev,
                             calibration=as_dict(calibration, "calibration"),
                             metadata=as_dict(metadata, "metadata") or {}, created_utc=utc_now(),
                             chunk_frames=int(chunk_frames))
        self.flush_interval_s = float(flush_interval_s)
        self.flush_frames = int(flush_frames)
        if overwrite:
            for p in (self.path, self.jpath, partial_path(self.path)):
                p.unlink(missing_ok=True)

        self._record = jr.record_dtype(jr.payload_bytes(self.header))
        self._n_appended = 0
        self._n_synced = 0
        self._counters = dict.fromkeys(COUNTER_NAMES, 0)
        self._last_sync = time.monotonic()
        self._lock = threading.Lock()  # the journal fd and the counts above
        self._sync_lock = threading.Lock()  # one fsync at a time
        self._error: BaseException | None = None
        self._closed = False
        self._jfd = os.open(self.jpath, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_APPEND, 0o644)
        _write_all(self._jfd, jr.encode_header(self.header))
        os.fsync(self._jfd)
        fsync_dir(self.path.parent)

        self._background = bool(background)
        self._wake = threading.Event()
        self._stop = False
        self._thread: threading.Thread | None = None
        if self._background:
            self._thread = threading.Thread(target=self._run, name=f"SessionWriter({self.path.name})", daemon=True)
            self._thread.start()

    # ------------------------------------------------------------------ public API
    @property
    def kind(self) -> str:
        return self.header.kind

    @property
    def frame_shape(self) -> tuple[int, ...]:
        return self.header.frame_shape

    @property
    def frame_dtype(self) -> np.dtype:
        return self.header.spec.dtype

    @property
    def device(self) -> dict[str, Any]:
        return self.header.device

    @property
    def calibration(self) -> dict[str, Any] | None:
        return self.header.calibration

    @property
    def metadata(self) -> dict[str, Any]:
        return self.header.metadata

    def __enter__(self) -> SessionWriter:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    @property
    def n_frames(self) -> int:
        """Frames appended so far (each one in the journal: it survives the process being killed)."""
        return self._n_appended

    @property
    def n_synced(self) -> int:
        """Frames whose journal records have been fsync'd (they survive a power cut too)."""
        return self._n_synced

    def append(
        self,
        frames: ArrayLike,
        host_time_s: ArrayLike,
        valid: ArrayLike,
        seq: ArrayLike | None = None,
        device_time_us: ArrayLike | None = None,
    ) -> None:
        """Append a batch of ``N`` frames (or one frame without the batch axis).

        ``frames``: ``(N, *shape)`` — uint16-range integers for psm/daq, degrees for imu.
        ``host_time_s`` (s), ``valid``: ``(N,)`` (or scalars for one frame). ``seq``,
        ``device_time_us`` (µs): ``(N,)`` integers or None (stored as -1). When this
        returns, the batch is in the journal: it survives the process being killed.
        """
        self._check_usable()
        b = self._block(frames, host_time_s, valid, seq, device_time_us)
        n = len(b)
        if n == 0:
            return
        blob = jr.encode_frames(self._record, b)
        with self._lock:
            if self._closed:
                raise ValueError(f"{self.path}: writer is closed")
            _write_all(self._jfd, blob)
            self._n_appended += n
            due = (self._n_appended - self._n_synced >= self.flush_frames
                   or time.monotonic() - self._last_sync >= self.flush_interval_s)
        if due:
            if self._background:
                self._wake.set()
            else:
                self._sync()

    def set_counters(self, **counters: int) -> None:
        """Record the reader's error counters (cumulative values), e.g. ``dropped_frames=3``.

        Names: :data:`psmat.io.COUNTER_NAMES`. Written to the journal now.
        """
        self._check_usable()
        bad = set(counters) - set(COUNTER_NAMES)
        if bad:
            raise ValueError(f"unknown counter(s) {sorted(bad)}; known: {list(COUNTER_NAMES)}")
        values = {k: int(v) for k, v in counters.items()}
        for k, v in values.items():
            if v < 0:
                raise ValueError(f"counter {k} must be >= 0, got {v}")
        with self._lock:
            self._counters.update(values)
            _write_all(self._jfd, jr.encode_counters(self._record, self._counters))

    @property
    def counters(self) -> dict[str, int]:
        with self._lock:
            return dict(self._counters)

    def flush(self) -> None:
        """Fsync the journal now (blocking): every appended frame then survives a power cut."""
        self._check_usable()
        self._sync()

    def close(self) -> None:
        """Sync the journal, write the complete HDF5 file from it, remove the journal. Idempotent.

        Raises RuntimeError (keeping the journal, which :func:`psmat.io.load_session`
        recovers) if the file cannot be completed.
        """
        if self._closed:
            return
        if self._thread is not None:
            self._stop = True
            self._wake.set()
            self._thread.join()
        err = self._error
        with self._sync_lock:  # no fsync of a closed descriptor
            with self._lock:
                self._closed = True
            try:
                if err is None:
                    os.fsync(self._jfd)
            except OSError as e:
                err = e
            finally:
                os.close(self._jfd)
        if err is None:
            try:
                self._write_file()
            except Exception as e:  # noqa: BLE001 - whatever went wrong, the journal is kept
                err = e
        if err is not None:
            raise RuntimeError(
                f"{self.path}: the session could not be completed ({err}); the journal "
                f"{self.jpath} was kept — load_session() recovers it"
            ) from err
        self.jpath.unlink()
        fsync_dir(self.path.parent)

    # ------------------------------------------------------------------ internals
    def _write_file(self) -> None:
        """The journal, read back and checked record by record, becomes the HDF5 file."""
        j = jr.Journal.open(self.jpath)

        def checked() -> Iterator[FrameBatch]:
            yield from j.blocks()
            if j.frames_read != self._n_appended or j.damage_notes():  # before the file replaces PATH
                raise RuntimeError(f"journal damaged on disk while recording ({'; '.join(j.damage_notes())}; "
                                   f"{j.frames_read} of {self._n_appended} frames intact)")

        write_session_file(self.path, self.header, checked(), self._counters)

    def _block(self, frames: ArrayLike, host_time_s: ArrayLike, valid: ArrayLike, seq: ArrayLike | None,
               device_time_us: ArrayLike | None) -> FrameBatch:
        fr = np.asarray(frames)
        shape, dtype, kind = self.frame_shape, self.frame_dtype, self.kind
        if fr.shape == shape:
            fr = fr[None]
        if fr.shape[1:] != shape:
            raise ValueError(f"frames must have shape (N, {', '.join(map(str, shape))}), got {fr.shape}")
        n = fr.shape[0]
        if dtype.kind == "u":
            if fr.dtype.kind not in "ui" and not (fr.dtype.kind == "f" and np.all(fr == np.round(fr))):
                raise TypeError(f"{kind} frames must be integer counts, got dtype {fr.dtype}")
            if n and (fr.min() < 0 or fr.max() > np.iinfo(dtype).max):
                raise ValueError(f"{kind} counts out of uint16 range")
        elif fr.dtype.kind not in "uif":
            raise TypeError(f"{kind} frames must be real numbers, got dtype {fr.dtype}")
        return FrameBatch(
            frames=np.ascontiguousarray(fr, dtype=dtype),
            host_time_s=_per_frame(host_time_s, n, np.float64, "host_time_s"),
            valid=_per_frame(valid, n, np.bool_, "valid"),
            seq=np.full(n, -1, np.int64) if seq is None else _per_frame(seq, n, np.int64, "seq"),
            device_time_us=(np.full(n, -1, np.int64) if device_time_us is None
                            else _per_frame(device_time_us, n, np.int64, "device_time_us")),
        )

    def _check_usable(self) -> None:
        if self._closed:
            raise ValueError(f"{self.path}: writer is closed")
        if self._error is not None:
            raise RuntimeError(f"{self.path}: background journal sync failed: {self._error}") from self._error

    def _run(self) -> None:
        while not self._stop:
            self._wake.wait(self.flush_interval_s)
            self._wake.clear()
            try:
                self._sync()
            except OSError as e:  # surfaced by the next call
                self._error = e
                return

    def _sync(self) -> None:
        with self._sync_lock:
            with self._lock:
                if self._closed:
                    return
                n = self._n_appended
                self._last_sync = time.monotonic()
            os.fsync(self._jfd)
            self._n_synced = max(self._n_synced, n)


def _write_all(fd: int, data: bytes) -> None:
    mv = memoryview(data)
    while mv:
        k = os.write(fd, mv)
        mv = mv[k:]


def _per_frame(x: ArrayLike, n: int, dtype: Any, what: str) -> NDArray[Any]:
    a = np.asarray(x)
    if a.ndim == 0:
        a = np.full(n, a)
    if a.shape != (n,):
        raise ValueError(f"{what} must have shape ({n},), got {a.shape}")
    if np.dtype(dtype).kind == "i" and a.dtype.kind not in "ui" and a.size:
        if a.dtype.kind != "f" or not np.all(a == np.round(a)):
            raise TypeError(f"{what} must be integers, got dtype {a.dtype}")
    return a.astype(dtype)
