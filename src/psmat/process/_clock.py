"""When a recorded session's frames were taken: one time and one period per frame (docs/spec.md §6).

The sensor model creeps with time (eq. 2.23), so the chain steps it with each frame's own
period; a frame lost on the wire then advances it by its real interval. The clock is the
device's when the box stamps its frames (v2, ``device_time_us``), else the host's:

* **device clock**: the frames' own stamps. A frame whose stamp was lost (-1: it failed its
  check on the wire) is placed on the frame grid, interpolated between its neighbours (or the
  grid extended, at either end); a frame lost altogether is a longer period before the next.
  A box that restarted during the recording (it lost power, or was unplugged and reconnected)
  starts its clock again: where the stamps go back, the frames after it are a new segment of the
  device clock, placed after the one before by the host clock (each segment shifted by the median
  of host time minus device time over its frames, so the USB latency cancels).
* **host clock**: the host stamps a frame when the read that brought it returns, so the frames
  of one read share a stamp and their differences are not frame periods. The frames are taken
  as evenly spaced on the line through the first and the last stamped frame (the recording's
  mean period); a host clock cannot see a single lost frame (neither can v1 or csv framing).
  It can see a stretch of time in which no frame was taken or every frame was lost (a cable
  pulled and put back, a board stalled; :func:`psmat.io.host_gaps`): a step between two stamps longer
  than 1 s and 20 streaming periods, after which fewer frames arrived at once
  than half that step would have held (frames held back in a buffer arrive together and fill the
  step; frames never taken or lost do not). There the recording is cut, and each part's frames
  are placed back from its last stamp at the streaming period (the median over the reads of the
  time since the read before over the frames it brought): one line through all of them would give
  every frame of the recording a period stretched by the gap.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

__all__ = ["SessionClock", "session_clock"]


@dataclass(frozen=True)
class SessionClock:
    """The times of a session's frames on one clock.

    Attributes
    ----------
    t_s : ndarray (T,)
        Each frame's time (s), on the clock named by ``source``.
    periods_s : ndarray (T,)
        Each frame's time since the frame before it (s), all > 0; the first frame's is the
        median step. The sensor model's creep steps with them.
    source : {"device", "host"}
        ``device_time_us`` (v2) or ``host_time_s``.
    filled : int
        Frames without a stamp of their own, placed on the frame grid.
    restarts : int
        Times the device clock started again (its stamps went back): its segments were placed on
        the host clock (module docstring).
    gaps : int
        Stretches of the host clock without frames where the recording was cut
        (:func:`psmat.io.host_gaps`; module docstring).
    """

    t_s: NDArray[np.float64]
    periods_s: NDArray[np.float64]
    source: Literal["device", "host"]
    filled: int
    restarts: int = 0
    gaps: int = 0

    @property
    def step_s(self) -> float:
        """Median frame period (s); ``1/step_s`` is the frame rate (Hz)."""
        return float(np.median(self.periods_s))


def session_clock(session: Any) -> SessionClock:
    """Each frame's time and period of a loaded session (module docstring).

    Parameters
    ----------
    session : psmat.io.Session
        A loaded session (``device_time_us`` in µs, -1 unknown, or None; ``host_time_s`` in s,
        NaN unknown).

    Returns
    -------
    SessionClock

    Raises
    ------
    ValueError
        Fewer than two frames carry a time stamp, or the times do not advance from one frame
        to the next.
    """
    T = int(np.shape(session.counts)[0])
    dev = session.device_time_us
    restarts = 0
    if dev is not None and np.any(np.asarray(dev) >= 0):
        t, restarts = _device_seconds(np.asarray(dev, np.int64), np.asarray(session.host_time_s, np.float64))
        source: Literal["device", "host"] = "device"
    else:
        t = np.asarray(session.host_time_s, np.float64).copy()
        source = "host"
    known = np.flatnonzero(np.isfinite(t))
    if known.size < 2:
        raise ValueError(f"fewer than two of the session's {T} frames carry a time stamp: no frame period")
    k = np.arange(T)
    gaps = 0
    if source == "host":
        t, step, gaps = _host_seconds(t, known, k)
    else:
        step = float(np.median(np.diff(t[known]) / np.diff(known)))
        t = np.interp(k, known, t[known])
        t[: known[0]] = t[known[0]] - (known[0] - k[: known[0]]) * step  # lost at the start or the end:
        t[known[-1] + 1:] = t[known[-1]] + (k[known[-1] + 1:] - known[-1]) * step  # extend the grid
    if not step > 0:
        raise ValueError(f"the session's frame times do not advance ({source} clock, median step {step:g} s "
                         "between frames)")
    periods = np.diff(t, prepend=t[0] - step)
    if np.any(periods <= 0):
        j = int(np.flatnonzero(periods <= 0)[0])
        raise ValueError(f"the session's {source} clock does not advance at frame {j} ({float(t[j - 1])!r} s, then "
                         f"{float(t[j])!r} s)")
    return SessionClock(t, periods, source, int(T - known.size), restarts, gaps)


def _host_seconds(h: NDArray[np.float64], known: NDArray[np.intp],
                  k: NDArray[np.intp]) -> tuple[NDArray[np.float64], float, int]:
    """The frames' times from the host stamps ``h`` (NaN unknown; ``known`` their indices, ``k`` all), the
    first frame's period (s) and the gaps cut (module docstring)."""
    from ..io import host_gaps, streaming_period_s

    step = float((h[known[-1]] - h[known[0]]) / (known[-1] - known[0]))
    cuts = host_gaps(h) if step > 0 else np.zeros(0, np.intp)
    if cuts.size == 0:
        return h[known[0]] + (k - known[0]) * step, step, 0
    # each part back from its last stamp at the streaming period: its first read may be a burst of
    # frames taken before they arrived (held in a buffer while the port was away), which a line from
    # its first stamp would place after their arrival
    period = streaming_period_s(h)
    t = np.empty(k.size)
    starts = np.r_[0, cuts]
    stops = np.r_[cuts, k.size]
    for a, b in zip(starts, stops):
        last = known[(known >= a) & (known < b)][-1]   # the part's last stamped frame
        t[a:b] = h[last] - (last - k[a:b]) * period
    return t, period, int(cuts.size)


def _device_seconds(dev_us: NDArray[np.int64], host_s: NDArray[np.float64]) -> tuple[NDArray[np.float64], int]:
    """The device stamps (µs, -1 unknown) as seconds on the first segment's clock, NaN where unknown,
    and how often the clock started again (module docstring)."""
    from ..io import clock_restarts

    t = np.where(dev_us >= 0, dev_us * 1e-6, np.nan)
    cuts = clock_restarts(dev_us)  # the first frame of each new segment
    if cuts.size == 0:
        return t, 0
    bounds = np.r_[0, cuts, t.size]
    shift = np.empty(cuts.size + 1)
    for k, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
        d = host_s[a:b] - t[a:b]
        d = d[np.isfinite(d)]
        if d.size == 0:
            raise ValueError(f"the device clock started again at frame {int(bounds[k])}, and the frames "
                             f"{int(a)}-{int(b) - 1} have no host time to place them by")
        shift[k] = np.median(d)
    for k, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
        t[a:b] += shift[k] - shift[0]
    return t, int(cuts.size)
