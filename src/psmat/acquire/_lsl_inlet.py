"""Reading another program's LSL stream (a force platform, EEG) on psmat's host clock.

:class:`LslInlet` resolves a stream by name or type and pulls chunks whose LSL timestamps are
mapped to the host clock (``t + time_correction + offset``: :mod:`._lsl`). :class:`LslDevice`
puts the Device API over it (a puller thread, a ring buffer, :meth:`LslDevice.record_to` a
session stream), so ``psmat record --lsl NAME`` records it beside the mat.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._buffered import BufferedSource
from ._clock import HostClock
from ._errors import AcquireError
from ._lsl import LslClock, check_text, pylsl_module
from ._stats import DeviceStats

__all__ = ["LslChunk", "LslInlet", "LslDevice", "open_lsl"]

_FORMATS = {1: "float32", 2: "double64", 3: "string", 4: "int32", 5: "int16", 6: "int8", 7: "int64"}
_JOIN_S = 2.0


@dataclass(frozen=True)
class LslChunk:
    """Samples pulled from an inlet, oldest first.

    Attributes
    ----------
    values : ndarray, (N, channels)
        float64 for a numeric stream, str objects for a string stream.
    host_time_s : (N,) float64
        Each sample's time on the host clock (s).
    lsl_time_s : (N,) float64
        Its LSL timestamp as sent, on the sender's ``local_clock`` (s).
    """

    values: NDArray[Any]
    host_time_s: NDArray[np.float64]
    lsl_time_s: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.host_time_s.shape[0])


class LslInlet:
    """One LSL stream, resolved by name (or, when no stream has that name, by type) and pulled.

    Parameters
    ----------
    name_or_type : str
        The stream's name (e.g. ``"FP"``), or its type (``"EEG"``); a name wins.
    timeout_s : float
        Longest wait for the stream to be found, for its full description and for the first
        time-correction estimate (s).
    clock : HostClock, optional
        The host clock samples are mapped to (the recording's); default a new one.
    max_buffer_s : int
        Seconds of samples LSL keeps for this inlet between pulls.

    Raises
    ------
    AcquireError
        No such stream within ``timeout_s``.
    ValueError
        A name with quotes or line breaks.

    Notes
    -----
    ``host_time_s = lsl_time + time_correction + offset_s``: ``time_correction`` is LSL's
    estimate of the sender's clock against this machine's ``local_clock`` (0 within
    microseconds on one machine; re-read at every pull, LSL refreshes it in the background),
    ``offset_s`` this machine's ``local_clock`` against the host clock, measured once
    (:class:`~psmat.acquire.LslClock`).
    """

    def __init__(self, name_or_type: str, timeout_s: float = 5.0, *, clock: HostClock | None = None,
                 max_buffer_s: int = 360) -> None:
        pylsl = pylsl_module()
        key = check_text("stream name or type", name_or_type)
        if not (np.isfinite(timeout_s) and timeout_s > 0):
            raise ValueError(f"timeout_s must be > 0, got {timeout_s!r}")
        found = pylsl.resolve_bypred(f"name='{key}' or type='{key}'", 1, float(timeout_s))
        if not found:
            raise AcquireError(f"no LSL stream named (or of type) {key!r} found within {timeout_s:g} s")
        found.sort(key=lambda i: i.name() != key)  # a stream of that name before one of that type
        self._inlet = pylsl.StreamInlet(found[0], max_buflen=int(max_buffer_s), recover=True)
        try:
            self.info = self._inlet.info(timeout=float(timeout_s))  # the full description
            self._inlet.open_stream(timeout=float(timeout_s))
            self.time_correction_s = float(self._inlet.time_correction(timeout=float(timeout_s)))
        except Exception as exc:  # noqa: BLE001 - pylsl's TimeoutError / LostError: one line
            self.close()
            raise AcquireError(f"LSL stream {key!r} found but not readable: {type(exc).__name__}: {exc}") from None
        self.lsl_clock = LslClock(clock)
        self.numeric = self.info.channel_format() != pylsl.cf_string
        self._timeout = getattr(pylsl.util, "TimeoutError", TimeoutError)

    # -- what the stream is --------------------------------------------------------------
    @property
    def name(self) -> str:
        return str(self.info.name())

    @property
    def type(self) -> str:
        return str(self.info.type())

    @property
    def channel_count(self) -> int:
        return int(self.info.channel_count())

    @property
    def nominal_srate(self) -> float:
        """The sender's nominal rate (Hz); 0 for an irregular stream."""
        return float(self.info.nominal_srate())

    @property
    def source_id(self) -> str:
        return str(self.info.source_id())

    @property
    def channel_format(self) -> str:
        return _FORMATS.get(int(self.info.channel_format()), str(self.info.channel_format()))

    @property
    def channel_labels(self) -> list[str] | None:
        return _strings(self.info.get_channel_labels())

    @property
    def channel_units(self) -> list[str] | None:
        return _strings(self.info.get_channel_units())

    def description(self) -> dict[str, Any]:
        """The stream as a session's device dict: LSL's identity of it, channels, units, clock mapping."""
        return {"device": "lsl", "name": self.name, "type": self.type, "source_id": self.source_id,
                "hostname": str(self.info.hostname()), "uid": str(self.info.uid()),
                "nominal_srate_hz": self.nominal_srate, "channel_format": self.channel_format,
                "channel_count": self.channel_count, "channel_labels": self.channel_labels,
                "channel_units": self.channel_units,
                "lsl_to_host_offset_s": self.lsl_clock.offset_s,
                "time_correction_s": self.time_correction_s,
                "clock": "host_time_s = LSL timestamp + time_correction_s + lsl_to_host_offset_s; device_time_us = "
                         "the LSL timestamp on the sender's clock (us)"}

    # -- samples -------------------------------------------------------------------------
    def pull(self, timeout_s: float = 0.0, max_samples: int = 4096) -> LslChunk:
        """The samples that arrived (up to ``max_samples``), waiting up to ``timeout_s`` s for the first."""
        kw: dict[str, Any] = {"min_samples": 1} if timeout_s > 0 else {}
        values, stamps = self._inlet.pull_chunk(timeout=float(timeout_s), max_samples=int(max_samples),
                                                as_numpy=True, **kw)
        t = np.asarray(stamps, np.float64).reshape(-1)
        n = t.shape[0]
        if n == 0:
            vals = np.empty((0, self.channel_count), np.float64 if self.numeric else object)
            return LslChunk(vals, t, t)
        if self.numeric:
            vals = np.asarray(values, np.float64).reshape(n, self.channel_count)
        else:
            vals = np.array([[v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v) for v in row]
                             for row in values], dtype=object).reshape(n, self.channel_count)
        try:
            self.time_correction_s = float(self._inlet.time_correction(timeout=0.5))
        except self._timeout:  # keep the previous estimate
            pass
        return LslChunk(vals, self.lsl_clock.to_host(t + self.time_correction_s), t)

    def close(self) -> None:
        """Close the inlet (idempotent)."""
        inlet, self._inlet = getattr(self, "_inlet", None), None
        if inlet is not None:
            try:
                inlet.close_stream()
            except Exception:  # noqa: BLE001 - best effort
                pass
            del inlet

    def __enter__(self) -> LslInlet:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class LslDevice(BufferedSource):
    """A numeric LSL stream with the :class:`~psmat.acquire.Device` API (``kind="lsl"``).

    A thread pulls the inlet; between :meth:`start` and :meth:`stop` its samples go to a
    ring buffer (:meth:`read`) and, with :meth:`record_to`, to a session stream: float64
    frames of shape ``(channels,)``, ``host_time_s`` on the host clock, ``valid`` True,
    ``seq`` -1 (LSL numbers no samples), ``device_time_us`` the sender's LSL timestamp (µs).
    Made by :func:`open_lsl`.
    """

    kind = "lsl"
    _lost_what = "LSL stream"

    def __init__(self, inlet: LslInlet, *, buffer_frames: int = 60_000, poll_s: float = 0.05,
                 read_timeout_s: float = 1.0) -> None:
        if not inlet.numeric:
            raise ValueError(f"LSL stream {inlet.name!r} carries strings; only numeric streams are recorded")
        self.inlet = inlet
        self.port = f"lsl:{inlet.name}"
        self.shape: tuple[int, ...] = (inlet.channel_count,)
        self.dtype = np.dtype(np.float64)
        self.description = inlet.description()
        self.clock = inlet.lsl_clock.clock
        self.read_timeout_s = float(read_timeout_s)
        self._poll_s = float(poll_s)
        self._init_buffer(buffer_frames)
        self._lock = threading.Lock()
        self._started = False
        self._t_start = float("inf")
        self._closed = False
        self._gone = False
        self._frames = 0
        self._ignored = 0
        self._last_error: str | None = None
        self._halt = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"psmat-lsl({inlet.name})", daemon=True)
        self._thread.start()

    @property
    def started(self) -> bool:
        return self._started

    @property
    def stats(self) -> DeviceStats:
        """Counters as a :class:`DeviceStats` (``frames``: samples buffered since opening)."""
        return DeviceStats(frames=self._frames, invalid=0, dropped_wire=0, dropped_buffer=self._ring.dropped,
                           skipped_bytes=0, replies=0, reconnects=0, ignored=self._ignored, mismatched=0, bytes_in=0,
                           buffered=len(self._ring), connected=not (self._gone or self._closed),
                           last_error=self._last_error)

    def start(self) -> None:
        """Buffer (and record) the samples stamped from now on."""
        if self._closed:
            raise AcquireError(f"{self.port} is closed")
        with self._lock:
            self._t_start = self.clock.now()
            self._started = True

    def stop(self) -> None:
        """Stop buffering (samples already buffered stay readable)."""
        with self._lock:
            self._started = False

    def close(self) -> None:
        """Stop, end the puller thread, close the inlet (idempotent)."""
        if self._closed:
            return
        self.stop()
        self._closed = True
        self._halt.set()
        if self._thread is not threading.current_thread():
            self._thread.join(_JOIN_S)
        self._ring.wake()
        self.stop_recording()
        self.inlet.close()

    def _run(self) -> None:
        try:
            while not self._halt.is_set():
                chunk = self.inlet.pull(timeout_s=self._poll_s)
                if len(chunk):
                    self._handle(chunk)
        except Exception as exc:  # noqa: BLE001 - never let the puller die silently
            if not self._halt.is_set():
                self._last_error = f"LSL inlet: {type(exc).__name__}: {exc}"
                self._gone = True
            self._ring.wake()

    def _handle(self, chunk: LslChunk) -> None:
        with self._lock:
            keep = chunk.host_time_s >= self._t_start if self._started else np.zeros(len(chunk), bool)
            self._ignored += int((~keep).sum())
            if not keep.any():
                return
            frames = np.ascontiguousarray(chunk.values[keep], np.float64)
            n = frames.shape[0]
            host = chunk.host_time_s[keep]
            valid = np.ones(n, np.bool_)
            seq = np.full(n, -1, np.int64)
            dev = np.round(chunk.lsl_time_s[keep] * 1e6).astype(np.int64)
            self._frames += n
            self._deliver(frames, host, valid, seq, dev)


def open_lsl(name_or_type: str, timeout_s: float = 5.0, *, clock: HostClock | None = None,
             buffer_frames: int = 60_000) -> LslDevice:
    """Resolve a numeric LSL stream and read it as a device (:class:`LslDevice`, not started).

    Parameters
    ----------
    name_or_type : str
        The stream's name, or its type (:class:`LslInlet`).
    timeout_s : float
        Longest wait for it (s).
    clock : HostClock, optional
        The host clock its samples are put on (the recording's, shared with the mat).
    buffer_frames : int
        Ring-buffer capacity (samples).

    Raises
    ------
    AcquireError
        No such stream within ``timeout_s``.
    ValueError
        A string stream (markers), or a bad name.
    """
    inlet = LslInlet(name_or_type, timeout_s, clock=clock)
    try:
        return LslDevice(inlet, buffer_frames=buffer_frames)
    except BaseException:
        inlet.close()
        raise


def _strings(values: Any) -> list[str] | None:
    if not values:
        return None
    out = ["" if v is None else str(v) for v in values]
    return out if any(out) else None
