"""Events and conditions of a trial, and the Romberg quotient (docs/spec.md §7 "Events, conditions, Romberg").

A session's markers (``psmat.io.load_session(p).events``: host time in s, label) cut the
recording into *conditions*: each marker starts one, named by its label, that lasts until the
next marker or the end; a marker labelled ``end``, ``stop`` or ``off`` ends the current one
without starting another. :func:`load_events_csv` reads the same markers from a CSV file (an
experimenter's log). :func:`romberg_role` tells eyes-open from eyes-closed labels and
:func:`romberg` divides the metrics of the two: the Romberg quotient, eyes closed / eyes open.
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from numbers import Real
from pathlib import Path
from typing import Literal

__all__ = ["Condition", "conditions", "load_events_csv", "romberg_role", "romberg"]

#: labels (case-insensitive) that end the current condition without starting one
END_LABELS = frozenset({"end", "stop", "off"})
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


def load_events_csv(path: str | os.PathLike[str]) -> list[tuple[float, str]]:
    """Markers from a CSV file: header ``time_s,label`` (or ``time,label``), comma or semicolon separated
    (with semicolons, a time may have a decimal comma: ``12,5;eyes closed``).

    Parameters
    ----------
    path : path
        The file (UTF-8). Blank lines are skipped; labels keep their inner spaces, outer ones are stripped.

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
    text = p.read_text(encoding="utf-8-sig")
    lines = text.splitlines()
    first = next((i for i, line in enumerate(lines) if line.strip()), None)
    if first is None:
        raise ValueError(f"{p}: empty file (expected a header time_s,label)")
    delim = ";" if ";" in lines[first] and "," not in lines[first] else ","
    header = [h.strip().lower() for h in lines[first].split(delim)]
    if header not in (["time_s", "label"], ["time", "label"]):
        raise ValueError(f"{p}: line {first + 1}: header must be time_s,label (or time,label), got {lines[first]!r}")
    out = []
    for n, row in enumerate(csv.reader(lines[first + 1:], delimiter=delim), start=first + 2):
        if not row or not any(c.strip() for c in row):
            continue
        if len(row) != 2:
            raise ValueError(f"{p}: line {n}: expected 2 fields (time_s, label), got {len(row)}")
        try:  # a semicolon-separated file may write a decimal comma (0,5 s)
            t = float(row[0].replace(",", ".") if delim == ";" else row[0])
        except ValueError:
            raise ValueError(f"{p}: line {n}: time {row[0]!r} is not a number of seconds") from None
        if not math.isfinite(t):
            raise ValueError(f"{p}: line {n}: time {row[0]!r} is not finite")
        label = row[1].strip()
        if not label:
            raise ValueError(f"{p}: line {n}: empty label")
        out.append((t, label))
    return out


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
