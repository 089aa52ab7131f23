"""Events and conditions of a trial, and the Romberg quotient (docs/spec.md §7 "Events, conditions, Romberg").

A session's markers (``psmat.io.load_session(p).events``: host time in s, label) cut the
recording into *conditions*: each marker starts one, named by its label, that lasts until the
next marker or the end; a marker labelled ``end``, ``stop`` or ``off`` ends the current one
without starting another. :func:`load_events_csv` reads the same markers from a CSV file (an
experimenter's log). :func:`romberg_role` tells eyes-open from eyes-closed labels and
:func:`romberg` divides the metrics of the two: the Romberg quotient, eyes closed / eyes open.

Markers are stamped on the host clock (``Session.host_time_s``), but a trial is analysed on its
frame clock (the chain's ``clock.t_s``, or ``psmat.process.session_pressure(...).t_s``):
:func:`frame_clock` carries host times to it, :func:`condition_spans` cuts an analysed window of
that clock into its conditions (each with a unique label), and :func:`inside` picks the samples
of one. The study and the report both go this way, so the same frames fall in a condition
whatever bursts the host's arrival times come in.
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from numbers import Real
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from .._text import NotTextError, read_text
from .._wallclock import DAY_S, ClockTime, parse_clock
from ..units import header_unit, s_per_unit

__all__ = ["Condition", "conditions", "load_events_csv", "romberg_role", "romberg", "frame_clock",
           "condition_spans", "inside", "UNMARKED", "off_the_clock", "NEAR_S"]

#: labels (case-insensitive) that end the current condition without starting one
END_LABELS = frozenset({"end", "stop", "off"})
#: the label :func:`condition_spans` gives the stretch before the first marker ("" is the whole trial)
UNMARKED = "unmarked"
#: markers within this many seconds of a recording are taken to be on its clock (:func:`off_the_clock`)
NEAR_S = 3600.0
_EO = frozenset({"eyes open", "eo", "open"})
_EC = frozenset({"eyes closed", "ec", "closed"})


@dataclass(frozen=True)
class Condition:
    """One condition of a trial: ``label`` ("" = unmarked) from ``start_s`` to ``stop_s`` (s, the events' clock)."""

    label: str
    start_s: float
    stop_s: float

    @property
    def duration_s(self) -> float:
        """``stop_s - start_s`` (s)."""
        return self.stop_s - self.start_s


def _time(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(float(value)):
        raise ValueError(f"{name} must be a finite number of seconds, got {value!r}")
    return float(value)


def conditions(events: Iterable[tuple[float, str]], t0_s: float, t1_s: float) -> list[Condition]:
    """The conditions that markers cut the span ``[t0_s, t1_s]`` into.

    Parameters
    ----------
    events : iterable of (float, str)
        Markers: time (s, the clock of ``t0_s``/``t1_s``, e.g. a session's host clock) and label,
        in any order (sorted here, a stable sort: markers of one time keep their order).
    t0_s, t1_s : float
        The span of the recording (s), ``t0_s <= t1_s``.

    Returns
    -------
    list of Condition
        In time order. Each marker inside the span starts a condition named by its label that
        lasts until the next marker or ``t1_s``; the time before the first marker is
        ``Condition("", t0_s, first)`` (unmarked); labels ``end``, ``stop``, ``off``
        (case-insensitive, surrounding spaces ignored) end the current condition and start
        none. Markers outside the span are ignored; conditions of zero length are dropped.

    Raises
    ------
    ValueError
        A time that is not finite, or ``t1_s < t0_s`` (one line).
    """
    t0, t1 = _time("t0_s", t0_s), _time("t1_s", t1_s)
    if t1 < t0:
        raise ValueError(f"t1_s ({t1:g} s) is before t0_s ({t0:g} s)")
    marks = []
    for i, ev in enumerate(events):
        try:
            t, label = ev
        except (TypeError, ValueError):
            raise ValueError(f"event {i} is not a (time, label) pair: {ev!r}") from None
        if not isinstance(label, str):
            raise ValueError(f"event {i}: label must be a str, got {type(label).__name__}")
        t = _time(f"event {i}'s time", t)
        if t0 <= t <= t1:
            marks.append((t, label))
    marks.sort(key=lambda m: m[0])
    out: list[Condition] = []
    label: str | None = ""  # the current condition's label; None = none running
    start = t0
    for t, lab in marks:
        if label is not None and t > start:
            out.append(Condition(label, start, t))
        label = None if lab.strip().lower() in END_LABELS else lab
        start = t
    if label is not None and t1 > start:
        out.append(Condition(label, start, t1))
    return out


def frame_clock(host_s: Sequence[float] | NDArray[np.float64], frame_host_s: NDArray[np.float64],
                frame_t_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """Host-clock times (s) on the frame clock (s).

    Parameters
    ----------
    host_s : (E,) float
        Times on the session's host clock (s), e.g. its markers'.
    frame_host_s, frame_t_s : (N,) float
        Each frame's host arrival time (``Session.host_time_s``, s) and its time on the clock the
        trial is analysed on (the chain's ``clock.t_s``, s); non-finite pairs are ignored.

    Returns
    -------
    (E,) float
        Linear interpolation over the frames (arrival times that step back are held, so the
        mapping never decreases); of frames that arrived at one host time (a burst), the last —
        the newest the host had then — stands for them, so a marker stamped at a burst's arrival
        falls on that burst's last frame; before the first or after the last of these points,
        the line through the first and last (their mean slope).

    Raises
    ------
    ValueError
        Fewer than two frames with finite times on both clocks, or clocks of different lengths (one line).
    """
    h, t = np.asarray(frame_host_s, np.float64), np.asarray(frame_t_s, np.float64)
    if h.shape != t.shape:
        raise ValueError(f"{h.size} host times for {t.size} frame times")
    ok = np.isfinite(h) & np.isfinite(t)
    if ok.sum() < 2:
        raise ValueError("fewer than two frames with a host time: events cannot be placed")
    h, t = np.maximum.accumulate(h[ok]), t[ok]  # arrival times never step back for np.interp
    last = np.r_[h[1:] > h[:-1], True]  # frames arriving together (a burst): the newest stands for them
    h, t = h[last], t[last]
    x = np.asarray(host_s, np.float64)
    y = np.interp(x, h, t)
    slope = (t[-1] - t[0]) / (h[-1] - h[0]) if h[-1] > h[0] else 1.0
    y = np.where(x < h[0], t[0] + (x - h[0]) * slope, y)
    return np.where(x > h[-1], t[-1] + (x - h[-1]) * slope, y)


def off_the_clock(host_s: Sequence[float] | NDArray[np.float64], first_s: float, last_s: float) -> bool:
    """Whether markers are on another clock than a recording's: not one falls within :data:`NEAR_S`
    (an hour) of its first and last frames' host times (s).

    Most often they are seconds from the start where the host clock counts from 1970. Used anyway
    they would cut no condition, or label the whole trial with the last marker's condition (a marker
    before the recording starts a condition that is running when it begins); a marker set shortly
    before the recording is on its clock. No markers: False.
    """
    x = np.asarray(host_s, np.float64)
    return bool(x.size) and not np.any((x >= first_s - NEAR_S) & (x <= last_s + NEAR_S))


def condition_spans(events: Sequence[tuple[float, str]], lo_s: float, hi_s: float) -> list[Condition]:
    """The conditions of ``events`` inside an analysed window ``[lo_s, hi_s]`` (s).

    Parameters
    ----------
    events : sequence of (float, str)
        Markers already on the window's clock (s; :func:`frame_clock`) and their labels.
    lo_s, hi_s : float
        The window (s), ``lo_s <= hi_s``.

    Returns
    -------
    list of Condition
        :func:`conditions` of the markers cut to the window: one that began before ``lo_s`` (a
        marker before the window) starts there, one that goes on after ``hi_s`` stops there,
        none of zero length is kept. The stretch before the first marker is labelled
        :data:`UNMARKED`; a label used again gets `` (2)``, `` (3)``… from its second use on.
        No events, or only an unmarked stretch, is no condition (the whole window says it all).

    Raises
    ------
    ValueError
        As :func:`conditions` (one line).
    """
    if not events:
        return []
    times = [_time(f"event {i}'s time", t) for i, (t, _) in enumerate(events)]
    lo, hi = _time("lo_s", lo_s), _time("hi_s", hi_s)
    spans: list[Condition] = []
    seen: dict[str, int] = {}
    for c in conditions(events, min(lo, *times), max(hi, *times)):
        a, b = max(c.start_s, lo), min(c.stop_s, hi)
        if not b > a:
            continue
        label = c.label.strip() or UNMARKED
        seen[label] = seen.get(label, 0) + 1
        spans.append(Condition(label if seen[label] == 1 else f"{label} ({seen[label]})", a, b))
    return [] if all(s.label == UNMARKED for s in spans) else spans


def inside(t_s: NDArray[np.float64], span: Condition, hi_s: float) -> NDArray[np.bool_]:
    """Which samples at ``t_s`` (s) lie in ``span``: ``[start_s, stop_s)``, the stop included when it
    is the window's end ``hi_s`` (s), so consecutive spans share no sample and miss none."""
    t = np.asarray(t_s, np.float64)
    return (t >= span.start_s) & ((t < span.stop_s) | ((span.stop_s >= hi_s) & (t <= span.stop_s)))


_TIME_HEADERS = ("time", "onset")
_LABEL_HEADERS = ("label", "event", "marker", "condition", "annotation")


def load_events_csv(path: str | os.PathLike[str], *, utc_offset_s: float | None = None,
                    near_s: float | None = None) -> list[tuple[float, str]]:
    """Markers from a CSV file: header ``time_s,label`` (or ``time,label``), comma, semicolon or tab separated
    (with semicolons or tabs, a time may have a decimal comma: ``12,5;eyes closed``). The header may be
    written as people write it: ``Time (s)``, ``time_ms`` (converted to s), ``onset``; ``event``,
    ``marker``, ``condition`` for the label.

    A time may also be written by the clock on the wall (:func:`psmat._wallclock.parse_clock`): a date and
    time with its offset from UTC (``2024-03-01T10:32:15+01:00``) is exact; without it
    (``2024-03-01 10:32:15``) it is on the recording computer's clock, ``utc_offset_s`` east of UTC; a
    time of day (``10:32:15``) is also on the day of the recording, the one that puts it nearest
    ``near_s`` (a host time of the recording, s). Each is returned as a host time (s since 1970 UTC,
    as ``Session.host_time_s``).

    Parameters
    ----------
    path : path
        The file (UTF-8, UTF-16 with its byte-order mark, or Windows-1252). Blank lines are skipped; labels keep their inner spaces, outer ones are stripped.
    utc_offset_s : float, optional
        The recording computer's offset from UTC (s east; ``Session.utc_offset_s``); needed by wall-clock
        times without their offset.
    near_s : float, optional
        A host time of the recording (s, e.g. its first frame's); needed by times of day.

    Returns
    -------
    list of (float, str)
        (time in s, label), in the file's order.

    Raises
    ------
    FileNotFoundError
        No such file.
    ValueError
        A header other than those, or a bad row: one line naming the file and the line number.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"events file not found: {p}")
    try:
        text = read_text(p)
    except NotTextError as exc:
        raise ValueError(f"{p}: {exc}") from None
    lines = text.splitlines()
    first = next((i for i, line in enumerate(lines) if line.strip()), None)
    if first is None:
        raise ValueError(f"{p}: empty file (expected a header time_s,label)")
    # a spreadsheet's text (tabs) or European CSV (semicolons) may write a decimal comma (0,5 s)
    head = lines[first]
    delim = "\t" if "\t" in head else ";" if ";" in head and "," not in head else ","
    header = next(csv.reader([lines[first]], delimiter=delim))
    t_col, l_col = (header_unit(header[0], _TIME_HEADERS), header_unit(header[1], _LABEL_HEADERS)) if len(header) == 2 \
        else (None, None)
    if t_col is None or l_col is None or l_col[1] is not None:
        raise ValueError(f"{p}: line {first + 1}: header must be time_s,label (or time,label), got {lines[first]!r}")
    try:
        s_per = s_per_unit(t_col[1] or "s")
    except ValueError as exc:
        raise ValueError(f"{p}: line {first + 1}: {exc}") from None
    out = []
    for n, row in enumerate(csv.reader(lines[first + 1:], delimiter=delim), start=first + 2):
        if not row or not any(c.strip() for c in row):
            continue
        if len(row) != 2:
            raise ValueError(f"{p}: line {n}: expected 2 fields (time_s, label), got {len(row)}")
        try:
            t = float(row[0].replace(",", ".") if delim != "," else row[0]) * s_per
        except ValueError:
            clock = parse_clock(row[0])
            if clock is None:
                raise ValueError(f"{p}: line {n}: time {row[0]!r} is not a number of seconds, nor a clock time "
                                 "(10:32:15, 2024-03-01T10:32:15+01:00)") from None
            t = _host_time(clock, utc_offset_s, near_s, f"{p}: line {n}: time {row[0]!r}")
        if not math.isfinite(t):
            raise ValueError(f"{p}: line {n}: time {row[0]!r} is not finite")
        label = row[1].strip()
        if not label:
            raise ValueError(f"{p}: line {n}: empty label")
        out.append((t, label))
    return out


def _host_time(clock: ClockTime, utc_offset_s: float | None, near_s: float | None, where: str) -> float:
    """A wall-clock time as a host time (s since 1970 UTC), or ValueError saying what it needs."""
    if clock.kind == "aware":
        return clock.seconds
    if utc_offset_s is None:
        raise ValueError(f"{where} is the clock on the wall without its offset from UTC, and the recording does "
                         "not store its computer's (a session written before psmat stored it): write the "
                         "times with their offset (2024-03-01T10:32:15+01:00) or as seconds on the host clock")
    if clock.kind == "naive":
        return clock.seconds - float(utc_offset_s)
    if near_s is None:
        raise ValueError(f"{where} is a time of day: which day is not known without the recording")
    local = near_s + float(utc_offset_s)  # the recording, on the wall's clock
    day = math.floor(local / DAY_S) * DAY_S
    best = min((day + k * DAY_S + clock.seconds for k in (-1, 0, 1)), key=lambda x: abs(x - local))
    return best - float(utc_offset_s)


def romberg_role(label: str) -> Literal["EO", "EC"] | None:
    """``"EO"`` for an eyes-open label, ``"EC"`` for an eyes-closed one, else None.

    Eyes open: "eyes open", "EO", "open"; eyes closed: "eyes closed", "EC", "closed";
    case-insensitive, with ``_``, ``-`` and spaces alike (``"Eyes_Closed"`` is eyes closed).
    """
    key = re.sub(r"[\s_\-]+", " ", str(label)).strip().lower()
    if key in _EO:
        return "EO"
    if key in _EC:
        return "EC"
    return None


def romberg(eo: Mapping[str, float], ec: Mapping[str, float]) -> dict[str, float]:
    """The Romberg quotient: eyes closed / eyes open, for every metric both conditions have.

    Usually taken of the path (or mean velocity) and of the sway area; a quotient above 1
    means the sway grows when the eyes close.

    Parameters
    ----------
    eo, ec : mapping of str to float
        The metrics of the eyes-open and the eyes-closed condition (any units, the same in both).

    Returns
    -------
    dict of str to float
        ``romberg_<k>`` = ``ec[k] / eo[k]`` (dimensionless) for every key ``k`` of both whose two
        values are real numbers (bools and non-numbers left out), in ``eo``'s order; NaN where
        ``eo[k]`` is 0 or either value is NaN.
    """
    out = {}
    for k, a in eo.items():
        if k not in ec:
            continue
        b = ec[k]
        if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, Real) or not isinstance(b, Real):
            continue
        a, b = float(a), float(b)
        out[f"romberg_{k}"] = b / a if a != 0.0 and not (math.isnan(a) or math.isnan(b)) else math.nan
    return out
