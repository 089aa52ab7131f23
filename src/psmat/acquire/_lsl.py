"""Lab Streaming Layer (LSL): the host clock psmat stamps against LSL's clock, and the mat's outlets.

Two clocks meet here:

* psmat stamps every frame with :class:`~psmat.acquire.HostClock` (``host_time_s``: Unix-epoch
  seconds advanced by :func:`time.monotonic`);
* LSL stamps every sample with ``pylsl.local_clock()`` (liblsl's ``std::chrono::steady_clock``:
  seconds since an arbitrary origin, e.g. the machine's boot).

Both advance with the operating system's monotonic clock (``CLOCK_MONOTONIC`` on Linux, the
performance counter on Windows, ``mach_absolute_time`` on macOS: the clocks
:func:`time.monotonic` reads too), so on one machine they differ by a constant. :class:`LslClock`
measures it **once**, when it is made: the tightest of a few readings ``local_clock(),
host.now(), local_clock()`` gives ``offset_s = host − (l0 + l1) / 2`` (its uncertainty is half
the bracket, about a microsecond). Then

    lsl_time = host_time_s − offset_s        host_time_s = lsl_time + offset_s.

A sample from another machine carries that machine's ``local_clock``; LSL's inlet measures the
offset to this machine's (``StreamInlet.time_correction()``, NTP-like, refreshed in the
background), so a remote sample's host time is ``t + time_correction + offset_s``
(:class:`~psmat.acquire.LslInlet`).

``pylsl`` is optional (``pip install psmat[lsl]``): it is imported when an outlet, inlet or
clock is made, never when :mod:`psmat.acquire` is.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..io import frame_times
from ._clock import HostClock

__all__ = ["LslClock", "PressureOutlets", "pylsl_module", "channel_labels"]

#: what a stream's name, type and source id may hold: LSL's resolver takes them into an XPath
#: query, where a quote would end the string
_BAD_CHARS = "'\"\n\r\t"


def pylsl_module() -> Any:
    """``pylsl``, or ImportError with one line saying how to install it."""
    try:
        import pylsl
    except ImportError as exc:  # pragma: no cover - pylsl is in the test extra
        raise ImportError(f"Lab Streaming Layer support needs pylsl: pip install 'psmat[lsl]' ({exc})") from None
    return pylsl


def check_text(what: str, text: Any) -> str:
    """``text`` if it is a non-empty string LSL can resolve by (no quotes or line breaks), else ValueError."""
    if not isinstance(text, str) or not text or any(c in text for c in _BAD_CHARS) or len(text) > 200:
        raise ValueError(f"an LSL {what} is 1 ... 200 characters without quotes, tabs or line breaks, got {text!r}")
    return text


class LslClock:
    """The offset between psmat's host clock and LSL's ``local_clock``, measured once (module notes).

    Parameters
    ----------
    clock : HostClock, optional
        The host clock frames are stamped with (a :class:`~psmat.acquire.Device`'s ``clock``);
        default a new one.
    local_clock : callable, optional
        LSL's clock (s); default ``pylsl.local_clock``.
    readings : int
        Bracketed readings taken; the tightest one gives the offset.

    Attributes
    ----------
    offset_s : float
        ``host_time_s − lsl_time`` (s).
    uncertainty_s : float
        Half the tightest bracket (s): how far the offset may be from the truth.
    """

    def __init__(self, clock: HostClock | None = None, *, local_clock: Callable[[], float] | None = None,
                 readings: int = 9) -> None:
        if int(readings) < 1:
            raise ValueError(f"readings must be >= 1, got {readings!r}")
        self.clock = clock if clock is not None else HostClock()
        self.local_clock = local_clock if local_clock is not None else pylsl_module().local_clock
        best: tuple[float, float] | None = None
        for _ in range(int(readings)):
            l0 = self.local_clock()
            h = self.clock.now()
            l1 = self.local_clock()
            if best is None or l1 - l0 < best[0]:
                best = (l1 - l0, h - 0.5 * (l0 + l1))
        assert best is not None
        self.offset_s = float(best[1])
        self.uncertainty_s = float(best[0]) / 2

    def to_lsl(self, host_time_s: ArrayLike) -> NDArray[np.float64]:
        """Host times (s) as LSL ``local_clock`` times (s)."""
        return np.asarray(host_time_s, np.float64) - self.offset_s

    def to_host(self, lsl_time_s: ArrayLike) -> NDArray[np.float64]:
        """LSL ``local_clock`` times of this machine (s) as host times (s)."""
        return np.asarray(lsl_time_s, np.float64) + self.offset_s


def channel_labels(shape: tuple[int, int]) -> list[str]:
    """Labels of a mat's cells, row-major: ``r00c00``, ``r00c01``, ... (more digits past 100 rows or columns)."""
    r, c = (int(x) for x in shape)
    w = max(2, len(str(max(r, c) - 1)))
    return [f"r{i:0{w}d}c{j:0{w}d}" for i in range(r) for j in range(c)]


class PressureOutlets:
    """A mat's three LSL outlets: pressure frames, centre of pressure and markers.

    ============  ===========  ==========  ========  =========================================
    stream name   type         channels    format    rate
    ============  ===========  ==========  ========  =========================================
    NAME-pressure ``Pressure`` R·C, kPa    float32   the mat's (nominal), source id the serial
    NAME-cop      ``CoP``      2, cm       float32   the mat's (nominal): ``ml_cm``, ``ap_cm``
    NAME-markers  ``Markers``  1           string    irregular
    ============  ===========  ==========  ========  =========================================

    The pressure stream's description holds ``rows``, ``columns``, ``pitch_cm``, ``unit``
    (``kPa``), ``serial`` and one ``channels/channel`` per cell, row-major (``label`` ``rRRcCC``,
    ``unit`` kPa, ``type`` Pressure); the CoP's, its two channels in cm (M-L, A-P: docs/spec.md §7).
    Samples are stamped on LSL's clock from the frames' host times (:class:`LslClock`).

    Parameters
    ----------
    shape : (int, int)
        The mat's rows and columns.
    rate_hz : float
        Its frame rate (Hz), the streams' nominal rate.
    pitch_cm : float
        Cell pitch (cm), for the description.
    serial : str
        The box's serial number: the pressure stream's ``source_id`` (the CoP's and the
        markers' add ``/cop`` and ``/markers``); empty: ``psmat-NAME``.
    name : str
        Prefix of the streams' names.
    clock : HostClock, optional
        The clock the frames' host times are on (the device's); default a new one.
    """

    def __init__(self, shape: tuple[int, int], *, rate_hz: float, pitch_cm: float, serial: str = "",
                 name: str = "psmat", clock: HostClock | None = None) -> None:
        pylsl = pylsl_module()
        r, c = (int(x) for x in shape)
        if r < 1 or c < 1:
            raise ValueError(f"shape must be (R, C) with R, C >= 1, got {shape}")
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise ValueError(f"rate_hz must be > 0, got {rate_hz!r}")
        if not (np.isfinite(pitch_cm) and pitch_cm > 0):
            raise ValueError(f"pitch_cm must be > 0, got {pitch_cm!r}")
        check_text("stream name", name)
        source = check_text("source id", str(serial)) if serial else f"psmat-{name}"
        self.shape = (r, c)
        self.rate_hz = float(rate_hz)
        self.names = {"pressure": f"{name}-pressure", "cop": f"{name}-cop", "markers": f"{name}-markers"}
        self.lsl_clock = LslClock(clock)

        info = pylsl.StreamInfo(self.names["pressure"], "Pressure", r * c, self.rate_hz, pylsl.cf_float32, source)
        d = info.desc()
        for key, value in (("rows", r), ("columns", c), ("pitch_cm", f"{float(pitch_cm):g}"), ("unit", "kPa"),
                           ("serial", str(serial)), ("manufacturer", "psmat")):
            d.append_child_value(key, str(value))
        _channels(d, channel_labels(self.shape), "kPa", "Pressure")
        cinfo = pylsl.StreamInfo(self.names["cop"], "CoP", 2, self.rate_hz, pylsl.cf_float32, f"{source}/cop")
        cd = cinfo.desc()
        cd.append_child_value("unit", "cm")
        cd.append_child_value("serial", str(serial))
        _channels(cd, ["ml_cm", "ap_cm"], "cm", "CoP")
        minfo = pylsl.StreamInfo(self.names["markers"], "Markers", 1, pylsl.IRREGULAR_RATE, pylsl.cf_string,
                                 f"{source}/markers")
        self._pressure = pylsl.StreamOutlet(info)
        self._cop = pylsl.StreamOutlet(cinfo)
        self._markers = pylsl.StreamOutlet(minfo)
        self.pushed = 0
        self._last_host: float | None = None  # the last frame pushed (host time, s): the next push starts after it

    @classmethod
    def from_profile(cls, profile: Any, *, serial: str = "", name: str = "psmat", rate_hz: float | None = None,
                     clock: HostClock | None = None) -> PressureOutlets:
        """The outlets of a mat described by a :class:`psmat.Profile` (its shape, pitch and rate)."""
        if profile.geometry is None:
            raise ValueError(f"profile {profile.name!r} describes a {profile.kind} device, not a mat")
        return cls(tuple(profile.shape), rate_hz=float(rate_hz or profile.rate_hz),
                   pitch_cm=float(profile.geometry.pitch_cm), serial=serial, name=name, clock=clock)

    def push(self, processed: Any, host_time_s: ArrayLike, device_time_us: ArrayLike | None = None) -> int:
        """Push the pressure (kPa) and CoP (cm) of processed frames; the number of frames pushed.

        Parameters
        ----------
        processed : psmat.process.Processed
            The chain's products of T frames (``pressure_kpa`` (T, R, C), ``cop_cm`` (T, 2));
            a missing frame is pushed as NaN, keeping the time base.
        host_time_s : (T,) float
            The frames' host times (s, on ``clock``).
        device_time_us : (T,) int, optional
            Their device clock (µs, -1 unknown): frames that arrived together are spread by it
            (:func:`psmat.io.frame_times`).
        """
        if self._pressure is None:
            raise ValueError("the LSL outlets are closed")
        p = np.asarray(processed.pressure_kpa, np.float32)
        cop = np.asarray(processed.cop_cm, np.float32)
        T = p.shape[0]
        if p.shape != (T, *self.shape) or cop.shape != (T, 2):
            raise ValueError(f"pressure must be (T, {self.shape[0]}, {self.shape[1]}) and CoP (T, 2), "
                             f"got {p.shape} and {cop.shape}")
        if T == 0:
            return 0
        host = frame_times(host_time_s, device_time_us, after=self._last_host)  # in order across pushes too
        if host.shape != (T,):
            raise ValueError(f"host_time_s must have {T} values, got {host.shape}")
        if np.isfinite(host[-1]):
            self._last_host = float(host[-1])
        stamps = self.lsl_clock.to_lsl(host).tolist()
        self._pressure.push_chunk(p.reshape(T, -1), stamps)
        self._cop.push_chunk(cop, stamps)
        self.pushed += T
        return T

    def push_marker(self, label: str, host_time_s: float | None = None) -> None:
        """Push a marker ``label`` at a host time (s; default now)."""
        if self._markers is None:
            raise ValueError("the LSL outlets are closed")
        t = self.lsl_clock.clock.now() if host_time_s is None else float(host_time_s)
        self._markers.push_sample([str(label)], float(self.lsl_clock.to_lsl(t)))

    def have_consumers(self) -> bool:
        """Whether any inlet is connected to the pressure stream."""
        return self._pressure is not None and bool(self._pressure.have_consumers())

    def close(self) -> None:
        """Withdraw the three streams (idempotent)."""
        for attr in ("_pressure", "_cop", "_markers"):
            outlet = getattr(self, attr, None)
            if outlet is not None:
                setattr(self, attr, None)
                del outlet

    def __enter__(self) -> PressureOutlets:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _channels(desc: Any, labels: list[str], unit: str, kind: str) -> None:
    """``channels/channel`` entries (label, unit, type) in an LSL description, the XDF convention."""
    chans = desc.append_child("channels")
    for label in labels:
        ch = chans.append_child("channel")
        ch.append_child_value("label", label)
        ch.append_child_value("unit", unit)
        ch.append_child_value("type", kind)
