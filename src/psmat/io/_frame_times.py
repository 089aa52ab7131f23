"""Each frame's time on the host clock, when frames of one serial chunk share their arrival time.

A reader thread stamps every frame decoded from one serial chunk with the chunk's arrival time
(``host_time_s``), so frames that reached the host together — a busy host, a USB adapter's latency
timer — form a run of equal times. :func:`frame_times` spreads such a run back from its arrival:
by the device clock where every frame of the run has one, else by the device's frame period when
it is given, never back past the run before. :func:`run_end_period_s` estimates that period from
the frames that are at their arrival (each run's last). :func:`clock_restarts` finds where a device
clock started again (a box that restarted: its stamps go back). :func:`host_gaps` finds where the
host stamps have a stretch in which no frame was taken or every frame was lost (docs/spec.md §5),
:func:`streaming_period_s` the frame period while frames stream.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["frame_times", "run_end_period_s", "clock_restarts", "host_gaps", "streaming_period_s", "GAP_MIN_S",
           "GAP_PERIODS"]

#: a host-clock step shorter than this (s) is never a gap in the frames (:func:`host_gaps`)
GAP_MIN_S = 1.0
#: ... nor one shorter than this many streaming periods
GAP_PERIODS = 20
#: the frames stamped within this long (s) after a step arrived with it
_BURST_S = 0.1


def _runs(host: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """First and last index of each run of equal host times."""
    starts = np.flatnonzero(np.r_[True, host[1:] != host[:-1]])
    ends = np.r_[starts[1:], host.size] - 1
    return starts, ends


def run_end_period_s(host_time_s: ArrayLike) -> float:
    """The frame period (s) from the frames that are at their arrival: each run's last frame.

    ``(host at the last run's end − host at the first run's end) / (frames between them)``; NaN
    with fewer than two runs. Unlike the span of all frames over their count, it is not shortened
    when the first frames arrived together (their run's earlier frames were sent before its time).

    Parameters
    ----------
    host_time_s : (T,) float
        Host arrival times (s), not decreasing.
    """
    host = np.asarray(host_time_s, np.float64).reshape(-1)
    host = host[np.isfinite(host)]  # frames without a time are no arrival
    if host.size < 2:
        return float("nan")
    _, ends = _runs(host)
    if ends.size < 2 or not host[ends[-1]] > host[ends[0]]:
        return float("nan")
    return float(host[ends[-1]] - host[ends[0]]) / float(ends[-1] - ends[0])


def frame_times(host_time_s: ArrayLike, device_time_us: ArrayLike | None = None, *,
                period_s: float | None = None, after: float | None = None) -> NDArray[np.float64]:
    """Each frame's time on the host clock (s), frames of one serial chunk spread back from its arrival.

    Within a run of frames that share one ``host_time_s``:

    * when every frame's ``device_time_us`` is known and does not go back, frame ``k`` is put at
      ``host_last − (dev_last − dev_k)·1e-6``: the run's last frame at the arrival, the earlier
      ones as much earlier as the device clock says;
    * otherwise, with ``period_s``, frame ``k`` is put ``period_s`` before the next one;
    * otherwise the host time stays as it is.

    A run that would reach back to the run before it (one that arrived late: a busy host) is spread
    evenly between that run's arrival and its own instead, so the times never go back.

    Parameters
    ----------
    host_time_s : (T,) float
        Host arrival times (s), not decreasing.
    device_time_us : (T,) int, optional
        Device clock (µs), -1 where unknown.
    period_s : float, optional
        The device's frame period (s) for runs without a usable device clock (e.g.
        :func:`run_end_period_s`); must be positive and finite.
    after : float, optional
        The time (s) of the frame before these, e.g. the last of an earlier call on the same
        stream: the first run reaches back past it no more than past a run of this call.
    """
    host = np.asarray(host_time_s, np.float64).reshape(-1)
    out = host.copy()
    dev = None
    if device_time_us is not None:
        dev = np.asarray(device_time_us, np.int64).reshape(-1)
        if dev.shape != host.shape:
            raise ValueError(f"device_time_us must have shape {host.shape}, got {dev.shape}")
    if period_s is not None and not (np.isfinite(period_s) and period_s > 0):
        raise ValueError(f"period_s must be positive and finite, got {period_s!r}")
    if host.size < 2 or (dev is None and period_s is None):
        return out
    starts, ends = _runs(host)
    before = -np.inf if after is None else float(after)  # the last finite time before the run
    for s, e in zip(starts, ends):
        if e == s:  # one frame (or a frame without a time: NaN equals nothing)
            before = host[e] if np.isfinite(host[e]) else before
            continue
        d = dev[s:e + 1] if dev is not None else None
        back = None
        if d is not None and d.min() >= 0 and np.all(np.diff(d) >= 0):
            back = (d[-1] - d) * 1e-6
        elif period_s is not None:
            back = (e - np.arange(s, e + 1)) * float(period_s)
        if back is not None:
            if host[e] - back[0] > before:
                out[s:e + 1] = host[e] - back
            else:  # the device clock or the period reaches back past the run before: evenly after it instead
                m = e - s + 1
                out[s:e + 1] = before + (host[e] - before) * np.arange(1, m + 1) / m
        before = host[e]
    return out


def clock_restarts(device_time_us: ArrayLike) -> NDArray[np.intp]:
    """The frames at which a device clock started again: where its stamp goes back from the last
    known one (a box that lost power, or was unplugged and reconnected). Unknown stamps (-1) are
    passed over. Each returned index starts a new segment of the clock.

    Parameters
    ----------
    device_time_us : (T,) int
        Device clock (µs), -1 where unknown.
    """
    dev = np.asarray(device_time_us, np.int64).reshape(-1)
    known = np.flatnonzero(dev >= 0)
    return known[1:][dev[known[1:]] < dev[known[:-1]]]


def streaming_period_s(host_time_s: ArrayLike) -> float:
    """The frame period while frames stream (s): the median over the reads (runs of equal host times)
    of the time since the read before over the frames this one brought, so that a gap or a burst is one
    read among many; with fewer than 10 reads, the mean period through the first and the last stamp.
    Unknown stamps (NaN) are passed over; NaN with fewer than two known."""
    host = np.asarray(host_time_s, np.float64).reshape(-1)
    known = np.flatnonzero(np.isfinite(host))
    if known.size < 2:
        return float("nan")
    hs = host[known]
    ends = np.r_[np.flatnonzero(np.diff(hs) > 0), hs.size - 1]   # the last frame of each read
    if ends.size < 11:
        return float((hs[-1] - hs[0]) / (known[-1] - known[0]))
    return float(np.median(np.diff(hs[ends]) / np.diff(known[ends])))


def host_gaps(host_time_s: ArrayLike) -> NDArray[np.intp]:
    """The frames after a stretch of the host clock in which no frame was taken or every frame was lost
    (a cable pulled and put back, a board stalled): a step between two stamps longer than
    :data:`GAP_MIN_S` and :data:`GAP_PERIODS` streaming periods (:func:`streaming_period_s`), after which
    the frames that arrived with it (within 0.1 s) would not fill half of it. Frames held back in a buffer
    arrive together and fill the step: no gap. Unknown stamps (NaN) are passed over; each returned index
    (a frame with a stamp) starts a new part.

    Parameters
    ----------
    host_time_s : (T,) float
        Arrival times (s), non-decreasing where known.
    """
    host = np.asarray(host_time_s, np.float64).reshape(-1)
    known = np.flatnonzero(np.isfinite(host))
    period = streaming_period_s(host)
    if known.size < 2 or not period > 0:
        return np.zeros(0, np.intp)
    hs = host[known]
    jumps = np.diff(hs)
    out = []
    for j in np.flatnonzero(jumps > max(GAP_MIN_S, GAP_PERIODS * period)):
        with_it = int(np.searchsorted(hs, hs[j + 1] + _BURST_S, side="right") - (j + 1))
        if with_it * period < jumps[j] / 2:   # the frames that arrived with it do not fill the step
            out.append(known[j + 1])
    return np.asarray(out, np.intp)
