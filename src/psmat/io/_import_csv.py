"""A generic CSV of pressure frames, one frame a line: a reader (docs/spec.md §6).

Each non-empty line is one frame: ``R·C`` numbers, the cells row by row (row 0's ``C`` cells,
then row 1's, ...), separated by commas, semicolons, tabs or spaces (one separator a line: the
first of ``;``, tab, ``,`` found, else spaces). A line separated by semicolons or tabs may write its
decimals with a comma (the European CSV: ``0,5;1,25``). An empty value (``1,,2``) is an error,
never skipped (it would shift the cells). The caller gives the shape
(``R``, ``C``), the pitch (cm) and either the frame rate (Hz: frame ``k`` at ``k / rate`` s) or a
first column of times: then each line holds ``1 + R·C`` numbers, the first the frame's time (s).
One header line (any line whose first field is not a number, e.g. ``time_s,r00c00_kpa,...``) is
skipped; a header whose first field is ``time``/``time_s``/``t`` says the time column is there.
Lines starting with ``#`` are comments.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..units import kpa_per_unit
from ._import_common import ImportedFrames, ImportFormatError, number, text_lines

__all__ = ["read_csv_frames"]



def _fields(s: str, where: str) -> list[str]:
    """A stripped line's values: split on its separator, a decimal comma read as a point after ``;`` or a
    tab (a spreadsheet's "text" in a European locale: ``0,5<tab>1,25``)."""
    if ";" in s or "\t" in s:
        fields = [f.strip().replace(",", ".") for f in s.split(";" if ";" in s else "\t")]
    elif "," in s:
        fields = [f.strip() for f in s.split(",")]
    else:
        return s.split()
    if len(fields) > 1 and not fields[-1]:
        fields.pop()  # a trailing separator
    if "" in fields:
        raise ImportFormatError(f"{where}: value {fields.index('') + 1} is empty")
    return fields


def read_csv_frames(path: str | Path, *, shape: tuple[int, int] | None = None, pitch_cm: float | None = None,
                    rate_hz: float | None = None, unit: str | None = None,
                    time_column: bool | None = None) -> ImportedFrames:
    """Read a CSV of frames, one a line.

    Parameters
    ----------
    path : path
        The file.
    shape : (int, int)
        Rows and columns of a frame (required).
    pitch_cm : float
        Sensel pitch (cm; required).
    rate_hz : float, optional
        Frame rate (Hz); required unless the file has a time column.
    unit : str, optional
        The values' pressure unit (default kPa).
    time_column : bool, optional
        Whether the first column holds the frame times (s); default: when the header names it
        (``time``, ``time_s``, ``t``) or no ``rate_hz`` is given.

    Raises
    ------
    ImportFormatError
        One line naming the file and line: a missing option, a line with the wrong number of
        values, a value that is not a number, times that do not increase.
    """
    p = Path(path)
    if shape is None or pitch_cm is None:
        raise ImportFormatError(f"{p}: a generic CSV needs --shape RxC and --pitch-cm P (they are not in the file)")
    R, C = (int(x) for x in shape)
    if not (R >= 1 and C >= 1 and pitch_cm > 0):
        raise ImportFormatError(f"{p}: shape {shape} and pitch {pitch_cm} cm must be positive")
    try:
        factor = kpa_per_unit(unit or "kPa")
    except ValueError as e:
        raise ImportFormatError(f"{p}: {e}") from None
    rows: list[list[float]] = []
    header_time = False
    saw_header = False
    nums: list[int] = []
    for ln, line in enumerate(text_lines(p), 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        fields = _fields(s, f"{p}:{ln}")
        try:
            float(fields[0])
        except ValueError:
            if rows or saw_header:
                raise ImportFormatError(f"{p}:{ln}: {fields[0][:40]!r} is not a number") from None
            saw_header = True
            header_time = fields[0].strip().lower() in ("time", "time_s", "t", "t_s")
            continue
        rows.append([number(f, f"{p}:{ln}") for f in fields])
        nums.append(ln)
    if not rows:
        raise ImportFormatError(f"{p}: no frame")
    has_time = time_column if time_column is not None else (header_time or rate_hz is None)
    want = R * C + (1 if has_time else 0)
    for vals, ln in zip(rows, nums):
        if len(vals) != want:
            raise ImportFormatError(f"{p}:{ln}: {len(vals)} values, expected {want} "
                                    f"({'a time and ' if has_time else ''}{R}x{C} cells)")
    a = np.asarray(rows, np.float64)
    if has_time:
        t = a[:, 0] - a[0, 0]
        cells = a[:, 1:]
        if np.any(np.diff(t) <= 0):
            k = int(np.flatnonzero(np.diff(t) <= 0)[0])
            raise ImportFormatError(f"{p}:{nums[k + 1]}: time does not increase")
    else:
        if rate_hz is None or not rate_hz > 0:
            raise ImportFormatError(f"{p}: no time column: give the frame rate (--rate-hz F)")
        t = np.arange(a.shape[0]) / float(rate_hz)
        cells = a
    return ImportedFrames((cells.reshape(-1, R, C) * factor).astype(np.float32), t, float(pitch_cm),
                          float(pitch_cm), "csv", unit or "kPa")
