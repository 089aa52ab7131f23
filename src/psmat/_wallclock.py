"""Clock times as people and their software write them in a table (docs/spec.md §6): a time of day
(``10:32:15``, ``23:59:59.990``), a date and time (``2024-03-01 10:32:15.25``), with or without its
offset from UTC (``...+01:00``, ``...Z``). A decimal comma is read as a point.

Read by the force-platform reader (any clock: only the lag to the mat matters) and the events
reader (the host clock: a time without its offset needs the recording computer's).
"""

from __future__ import annotations

import datetime as _dt
import re
from dataclasses import dataclass
from typing import Literal

__all__ = ["ClockTime", "parse_clock", "DAY_S"]

#: seconds in a day
DAY_S = 86400.0

_TIME_OF_DAY = re.compile(r"(\d{1,2}):([0-5]\d):([0-5]\d(?:[.,]\d*)?)")
_DATE_TIME = re.compile(r"(\d{4}-\d{2}-\d{2})[T ](\d{1,2}:[0-5]\d:[0-5]\d(?:[.,]\d*)?)(Z|[+-]\d{2}:?\d{2})?")


@dataclass(frozen=True)
class ClockTime:
    """A clock time read from a field.

    Attributes
    ----------
    kind : {"day", "naive", "aware"}
        ``day``: a time of day, ``seconds`` since its midnight; ``naive``: a date and time without
        its offset, ``seconds`` since 1970-01-01 00:00 on that same clock; ``aware``: a date and time
        with its offset, ``seconds`` POSIX time (since 1970-01-01 00:00 UTC).
    seconds : float
    """

    kind: Literal["day", "naive", "aware"]
    seconds: float


def parse_clock(field: str) -> ClockTime | None:
    """The clock time ``field`` holds, or None when it holds none (a plain number, text, a month 13)."""
    text = field.strip()
    m = _TIME_OF_DAY.fullmatch(text)
    if m:
        return ClockTime("day", int(m.group(1)) * 3600.0 + int(m.group(2)) * 60.0
                         + float(m.group(3).replace(",", ".")))
    m = _DATE_TIME.fullmatch(text)
    if not m:
        return None
    zone = m.group(3)
    try:
        d = _dt.datetime.fromisoformat(f"{m.group(1)}T{m.group(2).replace(',', '.')}"
                                       + ("" if zone is None else "+00:00" if zone == "Z" else zone))
    except ValueError:
        return None
    epoch = _dt.datetime(1970, 1, 1, tzinfo=None if zone is None else _dt.timezone.utc)
    whole = (d.replace(microsecond=0) - epoch).total_seconds()  # exact in whole seconds
    return ClockTime("naive" if zone is None else "aware", whole + d.microsecond * 1e-6)
