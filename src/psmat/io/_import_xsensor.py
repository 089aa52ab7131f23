"""XSENSOR CSV export (X3/Foresite "Export to CSV", one frame after another): a reader (docs/spec.md §6).

The layout read here (as XSENSOR's software writes it; the field names are those of its export):
each frame is a block of ``Name:,value`` lines, then the frame's ``Rows`` lines of ``Columns``
values separated by commas. psmat uses ``Frame:`` (starts a block), ``Date:`` and ``Time:``
(when the frame was taken: date ``YYYY-MM-DD``, ``DD/MM/YYYY``, ``DD.MM.YYYY`` or ``MM/DD/YYYY`` — read as
``YYYY-MM-DD``, with dots day first, with slashes month first unless the first number exceeds 12 — and time of day
``HH:MM:SS[.fff]``), ``Rows:``, ``Columns:``, ``Sensel Width (cm):``, ``Sensel Height (cm):``
and ``Units:`` (``mmHg``, ``PSI``, ``kPa``, ``N/cm2``; when absent, the unit in parentheses of
``Average Pressure (UNIT):`` or ``Peak Pressure (UNIT):``). Other fields (``Sensor:``, ``COP Row:``,
``Contact Area (cm^2):``, ...) are skipped; ``Sensor:`` is kept in the metadata. Frame times are the
stamps' differences from the first frame's. A frame's shape, sensel size and unit must be the
first frame's.
"""

from __future__ import annotations

import datetime as _dt
import re
from pathlib import Path

import numpy as np

from ..units import kpa_per_unit
from ._import_common import ImportedFrames, ImportFormatError, number, text_lines

__all__ = ["read_xsensor", "looks_like_xsensor"]

_FIELD = re.compile(r"\s*([A-Za-z][^:,]*?)\s*(?:\(([^)]*)\))?\s*:\s*,?(.*)")


def looks_like_xsensor(head: str) -> bool:
    """Whether the first lines of a file (``head``) are an XSENSOR CSV export."""
    low = head.lower()
    return "sensel width" in low or ("frame:" in low and "rows:" in low and "columns:" in low)


def _date(text: str, where: str) -> _dt.date:
    t = text.strip()
    try:
        if "-" in t:
            return _dt.date.fromisoformat(t[:10])
        if "." in t:  # DD.MM.YYYY, a German locale's: always day first
            d, mo, y = (int(x) for x in t.split("."))
            return _dt.date(y, mo, d)
        a, b, y = (int(x) for x in t.split("/"))
        return _dt.date(y, b, a) if a > 12 else _dt.date(y, a, b)
    except (ValueError, TypeError):
        raise ImportFormatError(f"{where}: date {t!r} is not YYYY-MM-DD, DD/MM/YYYY, DD.MM.YYYY or MM/DD/YYYY") from None


def _time_s(text: str, where: str) -> float:
    t = text.strip()
    m = re.fullmatch(r"(\d{1,2}):(\d{2}):(\d{2}(?:[.,]\d+)?)(?:\s*([AaPp][Mm]))?", t)
    if not m:
        raise ImportFormatError(f"{where}: time {t!r} is not HH:MM:SS[.fff]")
    h, mi, sec = int(m.group(1)), int(m.group(2)), float(m.group(3).replace(",", "."))
    if m.group(4):
        h = h % 12 + (12 if m.group(4).lower() == "pm" else 0)
    return h * 3600.0 + mi * 60.0 + sec


def read_xsensor(path: str | Path, *, unit: str | None = None) -> ImportedFrames:
    """Read an XSENSOR CSV export.

    Parameters
    ----------
    path : path
        The file.
    unit : str, optional
        The pressure unit, when the file names none (or to override it).

    Returns
    -------
    ImportedFrames
        Pressure in kPa; frame times from the frames' date and time stamps (s from the first).

    Raises
    ------
    ImportFormatError
        One line naming the file, the line and what is wrong.
    """
    p = Path(path)
    lines = text_lines(p)
    frames: list[np.ndarray] = []
    stamps: list[tuple[int, float]] = []  # (day number, s of the day): s since 2000 would lose µs
    first: dict[str, object] = {}
    cur: dict[str, tuple[str, str, int]] = {}
    i, n = 0, len(lines)

    def field(name: str, ln: int) -> str:
        if name not in cur:
            raise ImportFormatError(f"{p}:{ln}: frame {len(frames) + 1} lacks the field '{name}:'")
        return cur[name][1]

    while i < n:
        line = lines[i]
        if not line.strip().strip(","):
            i += 1
            continue
        m = _FIELD.match(line)
        if m:
            cur[m.group(1).strip().lower()] = (m.group(2) or "", m.group(3).split(",")[0].strip(), i + 1)
            i += 1
            continue
        if not cur:
            raise ImportFormatError(f"{p}:{i + 1}: values before any 'Frame:' block: not an XSENSOR CSV export")
        rows = int(number(field("rows", i + 1), f"{p}:{cur['rows'][2]}: Rows"))
        cols = int(number(field("columns", i + 1), f"{p}:{cur['columns'][2]}: Columns"))
        if not (1 <= rows <= 1024 and 1 <= cols <= 1024):
            raise ImportFormatError(f"{p}:{cur['rows'][2]}: Rows {rows} and Columns {cols} must be 1 ... 1024")
        block = np.empty((rows, cols), np.float64)
        for r in range(rows):
            if i >= n or not lines[i].strip().strip(",") or _FIELD.match(lines[i]):
                raise ImportFormatError(f"{p}:{i + 1}: frame {len(frames) + 1} has {r} rows, Rows says {rows}")
            cells = [c.strip() for c in lines[i].rstrip().rstrip(",").split(",")]
            if len(cells) != cols:
                raise ImportFormatError(f"{p}:{i + 1}: {len(cells)} values, Columns says {cols}")
            block[r] = [number(v, f"{p}:{i + 1}") for v in cells]
            i += 1
        ln = cur.get("frame", ("", "", i))[2]
        width = number(field("sensel width", ln), f"{p}:{cur['sensel width'][2]}: Sensel Width")
        height = number(field("sensel height", ln), f"{p}:{cur['sensel height'][2]}: Sensel Height")
        for key in ("sensel width", "sensel height"):
            u = cur[key][0].strip() or "cm"
            if u.lower() != "cm":
                raise ImportFormatError(f"{p}:{cur[key][2]}: {key} in {u!r}; psmat reads it in cm")
        name = unit or field("units", ln) if (unit or "units" in cur) else next(
            (cur[k][0] for k in ("average pressure", "peak pressure") if k in cur and cur[k][0]), "")
        t = _time_s(field("time", ln), f"{p}:{cur['time'][2]}")
        day = _date(cur["date"][1], f"{p}:{cur['date'][2]}").toordinal() if "date" in cur else 0
        this = {"shape": (rows, cols), "width": width, "height": height, "unit": name}
        if not first:
            first = this
        elif this != first:
            raise ImportFormatError(f"{p}:{ln}: frame {len(frames) + 1} differs from the first frame "
                                    f"({this} vs {first})")
        frames.append(block)
        stamps.append((day, t))
        cur = {k: v for k, v in cur.items() if k == "sensor"}
    if not frames:
        raise ImportFormatError(f"{p}: no frame (an XSENSOR CSV export has 'Frame:' blocks)")
    try:
        factor = kpa_per_unit(str(first["unit"]))
    except ValueError as e:
        raise ImportFormatError(f"{p}: {e}") from None
    t_s = np.array([(d - stamps[0][0]) * 86400.0 + (t - stamps[0][1]) for d, t in stamps])
    if len(stamps) > 1 and np.any(np.diff(t_s) <= 0):
        k = int(np.flatnonzero(np.diff(t_s) <= 0)[0])
        raise ImportFormatError(f"{p}: frame {k + 2}'s date and time are not after frame {k + 1}'s")
    extra = {"sensor": cur["sensor"][1]} if "sensor" in cur else {}
    width, height = float(first["width"]), float(first["height"])  # type: ignore[arg-type]
    return ImportedFrames((np.stack(frames) * factor).astype(np.float32), t_s, width, height, "xsensor",
                          str(first["unit"]), extra)
