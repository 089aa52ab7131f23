"""The conditions of a study session (docs/spec.md §7 "Events, conditions, Romberg"): its events,
recorded on the host clock (``Session.host_time_s``), brought to the clock the trial is analysed
on, and the aligned window cut into the spans that get rows of their own in ``metrics.csv``.

* :func:`frame_clock` — host times → the chain's frame clock ``t_s`` (linear interpolation over the
  frames' (host time, t) pairs, extended along the recording's mean slope outside it);
* :func:`condition_spans` — :func:`psmat.balance.conditions` of the events inside an analysed window,
  a condition that began before the window starting with it, labels made unique per session;
* :func:`inside` — which samples of a clock fall in a span.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..balance import conditions

__all__ = ["UNMARKED", "MIN_SAMPLES", "Span", "frame_clock", "condition_spans", "inside", "condition_of"]

#: the ``condition`` of the stretch before a session's first marker ("" is the whole trial)
UNMARKED = "unmarked"
#: fewest samples a condition needs for its metrics (as a whole trial)
MIN_SAMPLES = 8


@dataclass(frozen=True)
class Span:
    """One condition inside the analysed window: its row label and its start and stop (s, the window's clock)."""

    label: str
    start_s: float
    stop_s: float

    @property
    def duration_s(self) -> float:
        """``stop_s - start_s`` (s)."""
        return self.stop_s - self.start_s


def frame_clock(host_s: Sequence[float] | NDArray[np.float64], frame_host_s: NDArray[np.float64],
                frame_t_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """Host-clock times (s) on the frame clock (s).

    Parameters
    ----------
    host_s : (E,) float
        Times on the session's host clock (s), e.g. its markers'.
    frame_host_s, frame_t_s : (N,) float
        Each frame's host arrival time (``Session.host_time_s``, s) and its time on the chain's
        clock (``clock.t_s``, s); non-finite pairs are ignored.

    Returns
    -------
    (E,) float
        Linear interpolation over the frames; before the first or after the last frame, the line
        through the first and last frames (their mean slope).

    Raises
    ------
    ValueError
        Fewer than two frames with finite times on both clocks, or clocks of different lengths.
    """
    h, t = np.asarray(frame_host_s, np.float64), np.asarray(frame_t_s, np.float64)
    if h.shape != t.shape:
        raise ValueError(f"{h.size} host times for {t.size} frame times")
    ok = np.isfinite(h) & np.isfinite(t)
    if ok.sum() < 2:
        raise ValueError("fewer than two frames with a host time: events cannot be placed")
    h, t = np.maximum.accumulate(h[ok]), t[ok]  # arrival times never step back for np.interp
    x = np.asarray(host_s, np.float64)
    y = np.interp(x, h, t)
    slope = (t[-1] - t[0]) / (h[-1] - h[0]) if h[-1] > h[0] else 1.0
    y = np.where(x < h[0], t[0] + (x - h[0]) * slope, y)
    return np.where(x > h[-1], t[-1] + (x - h[-1]) * slope, y)


def condition_spans(events: Sequence[tuple[float, str]], lo_s: float, hi_s: float) -> list[Span]:
    """The conditions of ``events`` (already on the window's clock, s) inside the window ``[lo_s, hi_s]`` (s).

    A condition that began before ``lo_s`` starts there; one that goes on after ``hi_s`` stops
    there; none of zero length is kept. The stretch before the first marker is labelled
    :data:`UNMARKED`; a label used twice in a session gets `` (2)``, `` (3)``… from its second
    use on. No events, or only an unmarked stretch, is no span (the whole-trial rows say it all).
    """
    if not events:
        return []
    times = [float(t) for t, _ in events]
    conds = conditions(events, min(lo_s, *times), max(hi_s, *times))
    spans: list[Span] = []
    seen: dict[str, int] = {}
    for c in conds:
        a, b = max(c.start_s, lo_s), min(c.stop_s, hi_s)
        if not b > a:
            continue
        label = c.label.strip() or UNMARKED
        seen[label] = seen.get(label, 0) + 1
        spans.append(Span(label if seen[label] == 1 else f"{label} ({seen[label]})", a, b))
    return [] if all(s.label == UNMARKED for s in spans) else spans


def condition_of(row: Mapping[str, Any]) -> str:
    """The ``condition`` of a metrics row: its label, or "" for a whole-trial row (also when the
    row has no such column or holds no text there, as rows written before conditions existed)."""
    c = row.get("condition", "")
    return c if isinstance(c, str) else ""


def inside(t_s: NDArray[np.float64], span: Span, hi_s: float) -> NDArray[np.bool_]:
    """Samples at ``t_s`` (s) in ``span``: ``[start, stop)``, the stop included when it is the window's end ``hi_s``."""
    t = np.asarray(t_s, np.float64)
    return (t >= span.start_s) & ((t < span.stop_s) | ((span.stop_s >= hi_s) & (t <= span.stop_s)))
