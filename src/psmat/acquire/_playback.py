"""A recorded session played back through the Device API (after BrainFlow's playback board).

:func:`open_playback` loads a session file (:func:`psmat.io.load_session`) and returns a
:class:`PlaybackDevice`: ``read`` hands out the recorded frames at the times they were recorded
(divided by :attr:`PlaybackDevice.speed`), so that whatever reads a live device (``psmat view``,
the lab app) reads a recording the same way. The frames keep their recorded ``seq``,
``device_time_us`` and ``valid``; ``host_time_s`` is the playback's clock when they are read.

Timing: a frame is due ``t_k / speed`` seconds (of :func:`time.monotonic`) after playback
started, where ``t_k`` is its recorded time from the session's first frame: the device clock
(``device_time_us``) when every known device time runs forwards, else the host times
(``host_time_s``), else (no time at all) ``k / rate`` with the device's ``rate``. A frame whose
time is unknown (``-1`` or NaN: an invalid row, a damaged chunk) takes the time interpolated
between its neighbours, by index. Frames are released lazily in :meth:`PlaybackDevice.read`,
which waits on a condition variable until the next frame is due, its timeout ends, or another
thread pauses, resumes, seeks, changes the speed or closes (no thread of its own, no busy
loop).

A session with several devices (streams, ``psmat record --also``) plays its root device only;
its streams are left out (:attr:`PlaybackDevice.streams_left_out` names them).
"""

from __future__ import annotations

import math
import os
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._clock import HostClock
from ._errors import AcquireError
from ._ring_buffer import FrameBatch
from ._stats import DeviceStats

__all__ = ["PlaybackDevice", "open_playback", "recorded_times"]

#: shortest wait between two looks at the clock when a frame is almost due (s)
_MIN_WAIT_S = 5e-4
#: a seek to ``t`` starts with a frame recorded this close before ``t`` (s; float rounding)
_SEEK_EPS_S = 1e-9


def recorded_times(host_time_s: NDArray[np.float64], device_time_us: NDArray[np.int64] | None,
                   rate_hz: float | None = None) -> tuple[NDArray[np.float64], str]:
    """Each frame's recorded time from the first frame (s), non-decreasing, and which clock gave it.

    Parameters
    ----------
    host_time_s : ndarray (T,)
        Host receive times (s; NaN where unknown).
    device_time_us : ndarray (T,) or None
        Device clock (µs; -1 where unknown), or None when the device sent none.
    rate_hz : float, optional
        Frame rate (frames/s) used when neither clock is known for any frame.

    Returns
    -------
    times : ndarray of float64 (T,)
        ``times[0] == 0``; unknown times interpolated by index between known ones (held at
        the first / last known one at the ends); never decreasing (a host time that went
        backwards is held).
    clock : {"device_time_us", "host_time_s", "rate", "none"}
        The device clock (used when every known device time runs forwards), the host times,
        frame index over ``rate_hz``, or none (every frame at 0: all due at once).
    """
    n = int(np.asarray(host_time_s).shape[0])
    if n == 0:
        return np.zeros(0), "none"
    idx = np.arange(n, dtype=np.float64)
    t: NDArray[np.float64] | None = None
    clock = "none"
    if device_time_us is not None:
        dev = np.asarray(device_time_us, np.int64)
        known = dev >= 0
        if known.any() and np.all(np.diff(dev[known]) >= 0):
            # µs / 1e6 is rounded once: 500000 µs is exactly 0.5 s
            t = np.interp(idx, idx[known], (dev[known] - dev[known][0]) / 1e6)
            clock = "device_time_us"
    if t is None:
        host = np.asarray(host_time_s, np.float64)
        known = np.isfinite(host)
        if known.any():
            t = np.interp(idx, idx[known], host[known] - host[known][0])
            clock = "host_time_s"
        elif rate_hz is not None and math.isfinite(rate_hz) and rate_hz > 0:
            t = idx / float(rate_hz)
            clock = "rate"
        else:
            t = np.zeros(n)
    t = np.maximum.accumulate(t - t[0])
    return t, clock


class PlaybackDevice:
    """A recorded session read like a live :class:`~psmat.acquire.Device` (see :func:`open_playback`).

    Every method may be called from any thread (one lock and one condition variable guard the
    state): a lab server's request handler pauses, seeks or changes the speed while its reader
    thread blocks in :meth:`read`.

    Attributes
    ----------
    path : pathlib.Path
        The session file.
    port : str
        The session file's path as text (what a status line shows in place of a port).
    kind : {"psm", "imu", "daq"}
        The session's device kind.
    shape : tuple of int
        Frame shape, from the session (``(R, C)``, ``(5, 3)``, ``(10,)``).
    dtype : numpy.dtype
        The session's frame dtype (uint16 counts, float32 degrees).
    protocol : int, str or None
        The recorded device's protocol (its description's ``protocol`` or ``proto``).
    description : dict
        The session's device dict plus ``"playback"``: the session file's path.
    profile : dict or None
        The session's stored profile (``psmat.Profile.to_dict()``), None when it has none.
    metadata : dict
        The session's subject/trial metadata.
    events : list of (float, str)
        The session's markers (recorded host time s, label).
    clock : HostClock
        Stamps ``host_time_s`` of the frames :meth:`read` returns.
    timing : str
        Which recorded clock paces the playback (:func:`recorded_times`).
    times_s : ndarray of float64 (T,)
        Each frame's recorded time from the first frame (s), non-decreasing.
    loop : bool
        Start over at the end.
    read_timeout_s : float
        Longest wait of :meth:`read` when ``n`` is given without a timeout (s).
    streams_left_out : list of str
        The session's other devices (streams), which are not played.
    """

    def __init__(self, path: str | os.PathLike[str], *, speed: float = 1.0, loop: bool = False,
                 clock: HostClock | None = None, read_timeout_s: float = 1.0) -> None:
        from ..io import load_session

        speed = _check_speed(speed)
        self.path = Path(path)
        s = load_session(self.path)
        self.port = str(path)
        self.kind: str = s.kind
        self.shape: tuple[int, ...] = s.frame_shape
        self.dtype = np.dtype(s.counts.dtype)
        self.description: dict[str, Any] = {**dict(s.device), "playback": str(path)}
        self.protocol: Any = s.device.get("protocol", s.device.get("proto"))
        self.profile: dict[str, Any] | None = dict(s.profile) if s.profile is not None else None
        self.metadata: dict[str, Any] = dict(s.metadata)
        self.events: list[tuple[float, str]] = list(s.events)
        self.streams_left_out: list[str] = sorted(s.streams)
        self.clock = clock if clock is not None else HostClock()
        self.loop = bool(loop)
        self.read_timeout_s = float(read_timeout_s)
        n = s.n_frames
        self._frames = s.counts
        self._valid = np.asarray(s.valid, np.bool_)
        self._seq = np.asarray(s.seq, np.int64) if s.seq is not None else np.full(n, -1, np.int64)
        self._dev_us = (np.asarray(s.device_time_us, np.int64) if s.device_time_us is not None
                        else np.full(n, -1, np.int64))
        rate = _rate(s.device, s.profile)
        self.times_s, self.timing = recorded_times(s.host_time_s, s.device_time_us, rate)
        self._n = n
        period = float(np.median(np.diff(self.times_s))) if n >= 2 else 0.0
        if not period > 0:
            period = 1.0 / rate if rate else 0.01
        #: the length of one pass when looping: the last frame, then one frame period
        self._cycle_s = float(self.times_s[-1]) + period if n else period
        self._lock = threading.RLock()
        self._cond = threading.Condition(self._lock)
        self._speed = speed
        self._next = 0               # index of the next frame to release
        self._anchor_pos = 0.0       # session time (s) reached at _anchor_mono
        self._anchor_mono = time.monotonic()
        self._started = False
        self._paused = False
        self._closed = False
        self._played_valid = 0
        self._played_invalid = 0
        self._loops = 0

    # -- properties ----------------------------------------------------------------------
    @property
    def speed(self) -> float:
        """Playback speed: recorded seconds per second (> 0; ``inf``: as fast as :meth:`read` asks)."""
        return self._speed

    @speed.setter
    def speed(self, value: float) -> None:
        value = _check_speed(value)
        with self._cond:
            self._reanchor()
            self._speed = value
            self._cond.notify_all()

    @property
    def duration_s(self) -> float:
        """Recorded time from the first to the last frame (s)."""
        return float(self.times_s[-1]) if self._n else 0.0

    @property
    def n_frames(self) -> int:
        """Frames in the session (one pass)."""
        return self._n

    @property
    def position_s(self) -> float:
        """Session time reached (s from the session's first frame, 0 ... :attr:`duration_s`)."""
        with self._lock:
            return min(self._position(time.monotonic()), self.duration_s)

    @property
    def finished(self) -> bool:
        """Every frame has been read (never with ``loop``)."""
        with self._lock:
            return not self.loop and self._next >= self._n

    @property
    def paused(self) -> bool:
        """Whether :meth:`pause` holds the playback."""
        return self._paused

    @property
    def started(self) -> bool:
        """Whether the playback is started (between :meth:`start` and :meth:`stop`)."""
        return self._started

    @property
    def connected(self) -> bool:
        """True until :meth:`close` (a file does not vanish like a port)."""
        return not self._closed

    @property
    def loops(self) -> int:
        """Passes completed when looping."""
        return self._loops

    @property
    def stats(self) -> DeviceStats:
        """Counters: ``frames`` / ``invalid`` are the valid / invalid frames played (read);
        ``buffered`` the frames due but not read yet; the link counters are 0."""
        with self._lock:
            due = 0 if not self._playing() else self._due(self._position(time.monotonic())) - self._next
            return DeviceStats(frames=self._played_valid, invalid=self._played_invalid, dropped_wire=0,
                               dropped_buffer=0, skipped_bytes=0, replies=0, reconnects=0, ignored=0, mismatched=0,
                               bytes_in=0, buffered=max(due, 0), connected=not self._closed, last_error=None)

    def __repr__(self) -> str:
        state = "closed" if self._closed else ("paused" if self._paused else
                                               ("playing" if self._started else "stopped"))
        return (f"<PlaybackDevice {self.kind} {self.shape} of {self.port!r} at {self._speed:g}x, {state}, "
                f"{self.position_s:.2f} / {self.duration_s:.2f} s>")

    # -- lifecycle -----------------------------------------------------------------------
    def start(self) -> None:
        """Start (or, after :meth:`stop`, continue) the playback from the current position."""
        with self._cond:
            self._check_open()
            if not self._started:
                self._reanchor()
                self._started = True
                self._cond.notify_all()

    def stop(self) -> None:
        """Stop the playback where it is (:meth:`start` continues it); frames not read stay."""
        with self._cond:
            if self._started:
                self._reanchor()
                self._started = False
                self._cond.notify_all()

    def pause(self) -> None:
        """Hold the playback: :meth:`read` returns no frame until :meth:`resume`."""
        with self._cond:
            if not self._paused:
                self._reanchor()
                self._paused = True
                self._cond.notify_all()

    def resume(self) -> None:
        """Continue after :meth:`pause` from where it stopped."""
        with self._cond:
            if self._paused:
                self._reanchor()
                self._paused = False
                self._cond.notify_all()

    def seek(self, t_s: float) -> None:
        """Continue from session time ``t_s`` (s from the first frame; clamped to 0 ... duration).

        The next frame read is the first one recorded at or after ``t_s``; paused or not stays as is.
        """
        t = float(t_s)
        if not math.isfinite(t):
            raise ValueError(f"seek needs a finite time in s, got {t_s!r}")
        t = min(max(t, 0.0), self.duration_s)
        with self._cond:
            self._next = int(np.searchsorted(self.times_s, t - _SEEK_EPS_S, "left"))
            self._anchor_pos = t
            self._anchor_mono = time.monotonic()
            self._cond.notify_all()

    def close(self) -> None:
        """End the playback (idempotent); a waiting :meth:`read` returns at once."""
        with self._cond:
            self._started = False
            self._closed = True
            self._cond.notify_all()

    def __enter__(self) -> PlaybackDevice:
        if not self._started:
            self.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def record_to(self, writer: Any) -> None:
        """Not supported: raises :class:`AcquireError` (a replay is not recorded again)."""
        raise AcquireError(f"a replay is not recorded again: {self.port} is already a session file (copy it instead)")

    def stop_recording(self) -> None:
        """Nothing to stop (a playback never records)."""

    # -- reading -------------------------------------------------------------------------
    def read(self, n: int | None = None, timeout_s: float | None = None) -> FrameBatch:
        """Take the frames that are due, oldest first.

        Parameters
        ----------
        n : int, optional
            Frames wanted. None: every frame due now (at most one pass of the session), waiting
            up to ``timeout_s`` s for at least one when ``timeout_s`` is given.
        timeout_s : float, optional
            Longest wait for ``n`` frames (s); None means :attr:`read_timeout_s`. Never blocks
            forever: on timeout, when paused, stopped, finished or closed it returns what it has.

        Returns
        -------
        FrameBatch
            Up to ``n`` frames (possibly none): recorded ``frames``, ``valid``, ``seq``,
            ``device_time_us``; ``host_time_s`` = :attr:`clock` now.
        """
        if n is not None and (isinstance(n, bool) or int(n) != n or n < 0):
            raise ValueError(f"n must be an integer >= 0, got {n!r}")
        want = 1 if n is None else int(n)
        limit = max(self._n, 1) if n is None else int(n)
        waits = want > 0 and (n is not None or timeout_s is not None)
        wait_s = (self.read_timeout_s if timeout_s is None else float(timeout_s)) if waits else 0.0
        deadline = time.monotonic() + wait_s
        pieces: list[tuple[int, int]] = []
        got = 0
        with self._cond:
            while True:
                got += self._take(limit - got, pieces)
                if got >= want or self._closed:
                    break
                now = time.monotonic()
                left = deadline - now
                if left <= 0:
                    break
                until = self._until_next(now)
                self._cond.wait(left if until is None else min(left, max(until, _MIN_WAIT_S)))
            batch = self._batch(pieces)
            self._played_valid += int(batch.valid.sum())
            self._played_invalid += int(len(batch) - batch.valid.sum())
        return batch

    # -- internals (called with the lock held) -------------------------------------------
    def _check_open(self) -> None:
        if self._closed:
            raise AcquireError(f"playback of {self.port} is closed")

    def _playing(self) -> bool:
        return self._started and not self._paused and not self._closed

    def _position(self, now: float) -> float:
        """Session time reached (s; may pass the end of a pass while looping)."""
        if not self._playing():
            return self._anchor_pos
        if math.isinf(self._speed):  # as fast as read: the newest frame released so far
            last = float(self.times_s[self._next - 1]) if self._next > 0 else 0.0
            return max(self._anchor_pos, last)
        return self._anchor_pos + (now - self._anchor_mono) * self._speed

    def _reanchor(self) -> None:
        now = time.monotonic()
        self._anchor_pos = self._position(now)
        self._anchor_mono = now

    def _due(self, pos: float) -> int:
        """Frames of this pass due at session time ``pos`` (an index past the last one due)."""
        if math.isinf(self._speed):
            return self._n
        return int(np.searchsorted(self.times_s, pos, "right"))

    def _take(self, limit: int, pieces: list[tuple[int, int]]) -> int:
        """Release up to ``limit`` due frames into ``pieces`` (index ranges); how many."""
        got = 0
        while got < limit and self._playing() and self._n:
            pos = self._position(time.monotonic())
            due = self._due(pos)
            if due > self._next:
                stop = min(due, self._next + limit - got)
                pieces.append((self._next, stop))
                got += stop - self._next
                self._next = stop
                continue
            if not (self.loop and self._next >= self._n and (math.isinf(self._speed) or pos >= self._cycle_s)):
                break
            # the pass is over: start again, keeping the time past its end
            self._anchor_pos = 0.0 if math.isinf(self._speed) else self._anchor_pos - self._cycle_s
            self._next = 0
            self._loops += 1
        return got

    def _until_next(self, now: float) -> float | None:
        """Wall seconds until the next frame is due, or None when none will come without a call."""
        if not self._playing() or not self._n:
            return None
        if math.isinf(self._speed):
            return 0.0
        pos = self._position(now)
        if self._next < self._n:
            return (float(self.times_s[self._next]) - pos) / self._speed
        if self.loop:
            return (self._cycle_s - pos) / self._speed
        return None

    def _batch(self, pieces: list[tuple[int, int]]) -> FrameBatch:
        if not pieces:
            return FrameBatch.empty(self.shape, self.dtype)
        idx = np.concatenate([np.arange(a, b) for a, b in pieces])
        return FrameBatch(self._frames[idx], np.full(idx.size, self.clock.now(), np.float64), self._valid[idx].copy(),
                          self._seq[idx].copy(), self._dev_us[idx].copy())


def _check_speed(value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"speed must be a number > 0 (inf: as fast as read), got {value!r}") from None
    if isinstance(value, bool) or not v > 0:  # NaN fails too
        raise ValueError(f"speed must be a number > 0 (inf: as fast as read), got {value!r}")
    return v


def _rate(device: dict[str, Any], profile: dict[str, Any] | None) -> float | None:
    """The recorded frame rate (frames/s) from the device's description, else its profile, else None."""
    for d, key in ((device, "rate"), (profile or {}, "rate_hz"), (profile or {}, "rate")):
        try:
            v = float(d.get(key))  # type: ignore[arg-type]
        except (TypeError, ValueError):
            continue
        if math.isfinite(v) and v > 0:
            return v
    return None


def open_playback(path: str | os.PathLike[str], *, speed: float = 1.0, loop: bool = False,
                  start: bool = True, **options: Any) -> PlaybackDevice:
    """Open a recorded session for playback through the Device API.

    Parameters
    ----------
    path : str or Path
        A session file (:func:`psmat.io.load_session`: a finished file, or the journal of a
        recording that was not closed). A psm, imu or daq session; a session with streams plays
        its root device only.
    speed : float
        Recorded seconds per second of playback (> 0; 2 = twice as fast; ``float("inf")``: every
        frame as soon as it is read). Settable later (:attr:`PlaybackDevice.speed`).
    loop : bool
        Start over after the last frame (one frame period after it).
    start : bool
        Start playing now (else call :meth:`PlaybackDevice.start`, or use it in a ``with``).
    **options
        ``clock`` (a :class:`HostClock` stamping ``host_time_s``), ``read_timeout_s``.

    Returns
    -------
    PlaybackDevice

    Raises
    ------
    FileNotFoundError
        Neither the file nor its journal exists.
    psmat.io.SessionFormatError
        Not a session file (one line naming it).
    ValueError
        ``speed`` not > 0.
    """
    dev = PlaybackDevice(path, speed=speed, loop=loop, **options)
    if start:
        dev.start()
    return dev
