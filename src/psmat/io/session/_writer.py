"""Writing a session: frames go to the journals as they arrive, to the HDF5 file when it closes.

:class:`StreamWriter` is the journal of one device's frames; :class:`SessionWriter` is the
first device's (the root of the file) and gathers the others (:meth:`SessionWriter.add_stream`),
each with its own journal ``PATH.NAME.journal``, into one file when it closes.
"""

from __future__ import annotations

import os
import threading
import time
import uuid
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..._atomic import fsync_dir, no_space
from ...frames import FrameBatch

from . import _journal as jr
from ._build import write_session_file
from ._events import EventsJournal, check_event, sort_events
from ._layout import (
    COUNTER_NAMES,
    local_utc_offset_s,
    MAX_CHUNK_FRAMES,
    Header,
    StreamBlocks,
    as_dict,
    check_stream_name,
    frame_shape_of,
    journal_path,
    partial_path,
    utc_now,
)

#: the journal is bytes: no newline translation on Windows (0 elsewhere)
_O_BINARY = getattr(os, "O_BINARY", 0)


class StreamWriter:
    """The crash-safety journal of one device's frames in a session being written (docs/spec.md §6).

    Made by :meth:`SessionWriter.add_stream` (and the root device's is the
    :class:`SessionWriter` itself); closed with the session. Every appended frame is
    written to the journal before :meth:`append` returns, so it survives the process being
    killed; the journal is fsync'd every ``flush_interval_s`` s or ``flush_frames`` frames
    (on a writer thread when ``background``), so it survives a power cut up to the last sync.

    Thread safety: :meth:`append`, :meth:`set_counters` and :meth:`flush` may be called from
    any thread (calls are serialised internally, per stream); frames are stored in call order.
    """

    def __init__(self, jpath: Path, header: Header, *, session: str, name: str | None, label: str,
                 flush_interval_s: float, flush_frames: int, background: bool) -> None:
        if flush_frames < 1 or not flush_interval_s > 0:
            raise ValueError("flush_frames must be >= 1 and flush_interval_s > 0")
        self.name = name
        self.jpath = jpath
        self.header = header
        self.flush_interval_s = float(flush_interval_s)
        self.flush_frames = int(flush_frames)
        self._label = label
        self._record = jr.record_dtype(jr.payload_bytes(header))
        self._n_appended = 0
        self._n_synced = 0
        self._counters = dict.fromkeys(COUNTER_NAMES, 0)
        self._last_sync = time.monotonic()
        self._lock = threading.Lock()  # the journal fd and the counts above
        self._sync_lock = threading.Lock()  # one fsync at a time
        self._error: BaseException | None = None
        self._closed = False
        self._jfd = os.open(jpath, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_APPEND | _O_BINARY, 0o644)
        _write_all(self._jfd, jr.encode_header(header, session, stream=name))
        os.fsync(self._jfd)
        fsync_dir(jpath.parent)

        self._background = bool(background)
        self._wake = threading.Event()
        self._stop = False
        self._thread: threading.Thread | None = None
        if self._background:
            self._thread = threading.Thread(target=self._run, name=f"SessionWriter({label})", daemon=True)
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
                raise ValueError(f"{self._label}: writer is closed")
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

    # ------------------------------------------------------------------ internals
    def _close_journal(self) -> BaseException | None:
        """Stop the sync thread, sync and close the journal; the error that kept it from being whole, if any."""
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
        return err

    def _checked_blocks(self) -> Iterator[FrameBatch]:
        """The journal read back record by record; RuntimeError (before the file replaces PATH) if it lost any."""
        j = jr.Journal.open(self.jpath)
        yield from j.blocks()
        if j.frames_read != self._n_appended or j.damage_notes():
            raise RuntimeError(f"journal {self.jpath.name} damaged on disk while recording "
                               f"({'; '.join(j.damage_notes())}; {j.frames_read} of {self._n_appended} frames intact)")

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
            raise ValueError(f"{self._label}: writer is closed")
        if self._error is not None:
            raise RuntimeError(f"{self._label}: background journal sync failed: {self._error}") from self._error

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


class SessionNotCompleted(RuntimeError):
    """:meth:`SessionWriter.close` could not write the complete file (the disk full, the journal damaged,
    the file read back differing): the journals were kept, and :func:`psmat.io.load_session` recovers
    them (``psmat repair`` finishes the file)."""


class SessionWriter(StreamWriter):
    """Write a session to ``path`` with a crash-safety journal; use as a context manager.

    While recording, every appended frame is written to the journal ``PATH.journal`` before
    :meth:`append` returns; :meth:`close` turns the journal into the HDF5 file ``path``
    (which appears only then, complete) and removes the journal. A writer that is killed
    leaves the journal, which :func:`psmat.io.load_session` reads (docs/spec.md §6).

    More devices recorded with this one (e.g. the spine IMUs with the mat) are streams:
    :meth:`add_stream` returns a :class:`StreamWriter` with the same :meth:`append` (its own
    journal ``PATH.NAME.journal``); all of them go into the one file at :meth:`close`.

    Parameters
    ----------
    path : str or Path
        The ``.h5`` file to create. An existing file (or journal) is an error unless
        ``overwrite=True``.
    shape : tuple of int
        Frame shape: ``(R, C)`` for ``kind="psm"``, ``(5, 3)`` for ``"imu"`` (sensors ×
        heading/roll/pitch), ``(10,)`` (or ``10``) for ``"daq"``, ``(N,)`` for ``"lsl"`` (N
        channels of a Lab Streaming Layer stream, float64, usually a stream: :meth:`add_stream`),
        ``(R, C)`` for ``"pressure"`` (another mat's frames in kPa, float32:
        :func:`psmat.io.import_pressure`).
    device : dict
        Device description (serial, r_o, v_ref, bits, fw, protocol, rate, …; e.g. the
        parsed IDENTIFY reply). ``shape`` and ``kind`` are added if missing.
    calibration : dict or object with ``to_dict()``, optional
        The calibration used (e.g. :class:`psmat.Calibration`).
    metadata : dict, optional
        Subject/trial metadata (subject id, trial, condition, operator, notes, …).
    profile : dict or object with ``to_dict()``, optional
        The device profile the recording was made with (``psmat.Profile.to_dict()``),
        stored as ``/profile`` and loaded as :attr:`Session.profile`.
    kind : {"psm", "imu", "daq", "lsl", "pressure"}
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
        Replace an existing file: it stays as it is until :meth:`close` moves the new one over
        it (the journals of an interrupted recording at ``path`` are removed at once).

    Events (markers, :meth:`add_event`) go to their own journal ``PATH.events.journal``.

    Thread safety: :meth:`append`, :meth:`set_counters`, :meth:`add_event` and :meth:`flush` may
    be called from any thread (calls are serialised internally); frames are stored in call
    order. Each stream, and the events, has its own lock, so reader threads of different
    devices (and a thread marking events) do not wait for each other.
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
        profile: Any = None,
        flush_interval_s: float = 0.5,
        flush_frames: int = 512,
        background: bool = True,
        overwrite: bool = False,
    ) -> None:
        fshape = frame_shape_of(kind, shape)
        if not 1 <= chunk_frames <= MAX_CHUNK_FRAMES or flush_frames < 1 or not flush_interval_s > 0:
            raise ValueError(f"chunk_frames must be in [1, {MAX_CHUNK_FRAMES}], flush_frames >= 1 and "
                             "flush_interval_s > 0")
        self.path = Path(path)
        jpath = journal_path(self.path)
        ejpath = journal_path(self.path, "events")
        for p in (self.path, jpath, ejpath):
            if p.exists() and not overwrite:
                raise FileExistsError(f"{p} exists (pass overwrite=True to replace it)")
        header = Header(kind=kind, frame_shape=fshape, device=_device(device, kind, fshape),
                        calibration=as_dict(calibration, "calibration"),
                        metadata=as_dict(metadata, "metadata") or {}, created_utc=utc_now(),
                        chunk_frames=int(chunk_frames), profile=as_dict(profile, "profile"),
                        utc_offset_s=local_utc_offset_s())
        if overwrite:
            _remove_interrupted(self.path)
        self._overwrite = bool(overwrite)
        self._session = uuid.uuid4().hex  # ties the streams' journals to this recording's
        self._streams: dict[str, StreamWriter] = {}
        self._streams_lock = threading.Lock()
        self._events = EventsJournal(ejpath, self._session, header.created_utc)
        super().__init__(jpath, header, session=self._session, name=None, label=str(self.path), flush_interval_s=flush_interval_s,
                         flush_frames=flush_frames, background=background)

    # ------------------------------------------------------------------ public API
    @property
    def calibration(self) -> dict[str, Any] | None:
        return self.header.calibration

    @property
    def metadata(self) -> dict[str, Any]:
        return self.header.metadata

    @property
    def profile(self) -> dict[str, Any] | None:
        return self.header.profile

    @property
    def n_events(self) -> int:
        """Events added so far (each one on disk: it survives the process being killed)."""
        return self._events.n_events

    def add_event(self, host_time_s: float, label: str) -> None:
        """Mark an event of the recording: a host time and a label (e.g. ``"eyes closed"``).

        Parameters
        ----------
        host_time_s : float
            When, in s, on the clock of the frames' ``host_time_s`` (e.g. ``time.monotonic()``
            if the reader stamps frames with it). Events need not come in time order: the
            session holds them sorted by time.
        label : str
            At most 200 bytes of UTF-8 (any language), no NUL character.

        When this returns, the event is in the events journal ``PATH.events.journal`` and
        fsync'd: it survives the process being killed, and a power cut. Thread-safe (any
        thread, while others append frames).

        Raises
        ------
        ValueError
            A label longer than 200 bytes of UTF-8 or holding a NUL, a time that is not
            finite, or the writer is closed.
        TypeError
            A time that is not a number or a label that is not a str.
        """
        self._check_usable()
        t, raw = check_event(host_time_s, label)
        self._events.add(t, raw)

    @property
    def streams(self) -> dict[str, StreamWriter]:
        """The streams added so far, by name."""
        with self._streams_lock:
            return dict(self._streams)

    def __enter__(self) -> SessionWriter:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def add_stream(self, name: str, *, kind: str, shape: int | tuple[int, ...],
                   device: Mapping[str, Any]) -> StreamWriter:
        """Record another device in this session: a stream ``name`` with frames of ``kind`` and ``shape``.

        Parameters
        ----------
        name : str
            An ASCII identifier (e.g. ``"imu"``), not the name of a dataset or group of the
            session (``counts``, ``angles``, ``device``, …); the stream's frames are stored in
            the group ``/streams/NAME`` of the file.
        kind, shape, device
            As for the session (the device's description, its frame kind and shape).

        Returns
        -------
        StreamWriter
            Its :meth:`~StreamWriter.append` takes the stream's frames with times from the
            same host clock as the session's (thread-safe; a reader thread per device).

        Raises
        ------
        ValueError
            A bad or duplicate name, a bad kind or shape, or the session is closed.
        FileExistsError
            Its journal ``PATH.NAME.journal`` exists (without ``overwrite``).
        """
        check_stream_name(name)
        fshape = frame_shape_of(kind, shape)
        header = Header(kind=kind, frame_shape=fshape, device=_device(device, kind, fshape), calibration=None,
                        metadata={}, created_utc=self.header.created_utc, chunk_frames=self.header.chunk_frames)
        jpath = journal_path(self.path, name)
        with self._streams_lock:
            self._check_usable()
            if name in self._streams:
                raise ValueError(f"{self.path}: stream {name!r} already added")
            if jpath.exists():
                if not self._overwrite:
                    raise FileExistsError(f"{jpath} exists (pass overwrite=True to replace it)")
                jpath.unlink()
            w = StreamWriter(jpath, header, session=self._session, name=name, label=f"{self.path} stream {name!r}",
                             flush_interval_s=self.flush_interval_s, flush_frames=self.flush_frames,
                             background=self._background)
            self._streams[name] = w
        return w

    def flush(self) -> None:
        """Fsync every journal now (blocking): every appended frame then survives a power cut."""
        super().flush()
        for w in self.streams.values():
            w.flush()

    def close(self) -> None:
        """Sync the journals, write the complete HDF5 file from them, remove them. Idempotent.

        Raises :class:`SessionNotCompleted`, a RuntimeError (keeping the journals, which
        :func:`psmat.io.load_session` recovers) if the file cannot be completed, or if the file
        read back differs from the journals' frames (it then never replaces ``path``: :mod:`._verify`).
        """
        with self._streams_lock:
            if self._closed:
                return
            err = self._close_journal()  # no stream can be added from here on
            streams = dict(self._streams)
        for w in streams.values():
            err = w._close_journal() or err
        err = self._events.close() or err
        if err is None:
            try:
                events = sort_events(self._events.checked())  # read back: RuntimeError if it lost any
                # read back and checked against the journals' frames before it replaces PATH (._verify)
                write_session_file(self.path, self.header, self._checked_blocks(), self._counters,
                                   n_frames=self._n_appended, events=events,
                                   streams={name: StreamBlocks(w.header, w._checked_blocks(), w._counters,
                                                               w._n_appended)
                                            for name, w in streams.items()})
            except Exception as e:  # noqa: BLE001 - whatever went wrong, the journals are kept
                err = e
        ejpath = self._events.path if self._events.n_events else None
        if err is not None:
            kept = [str(p) for p in (self.jpath, *(w.jpath for w in streams.values()), ejpath) if p is not None]
            many = len(kept) > 1
            why = no_space(err) or err
            raise SessionNotCompleted(
                f"{self.path}: the session could not be completed ({why}); the journal{'s' if many else ''} "
                f"{', '.join(kept)} {'were' if many else 'was'} kept — load_session() recovers {'them' if many else 'it'}"
            ) from err
        if ejpath is not None:
            ejpath.unlink()
        for w in streams.values():
            w.jpath.unlink()
        self.jpath.unlink()  # last: while it is there, the side journals are still tied to a recording
        fsync_dir(self.path.parent)


def _device(device: Mapping[str, Any], kind: str, shape: tuple[int, ...]) -> dict[str, Any]:
    dev = as_dict(device, "device") or {}
    dev.setdefault("kind", kind)
    dev.setdefault("shape", list(shape))
    return dev


def _remove_interrupted(path: Path) -> None:
    """Before overwriting ``path``: the journal and the stream journals of its recording. The file
    itself stays until the new one replaces it (:meth:`SessionWriter.close`), so a recording that
    never closes costs nothing of it."""
    jpath = journal_path(path)
    try:
        session = jr.Journal.open(jpath).session if jpath.is_file() else None
    except (jr.SessionFormatError, OSError):
        session = None
    for j in jr.stream_journals(path, session)[0].values():
        j.path.unlink(missing_ok=True)
    for p in (journal_path(path, "events"), jpath, partial_path(path)):
        p.unlink(missing_ok=True)


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
