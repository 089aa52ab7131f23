"""Tekscan ASCII export (``.asf``/``.csv``, "Save ASCII" of F-Scan, I-Scan, ...): a reader (docs/spec.md §6).

The layout read here (as Tekscan's software writes it; the R package pressuRe's ``load_tekscan``
reads the same layout): header lines ``KEY value [unit]`` before the first frame, of which
psmat uses ``ROWS``, ``COLS`` (frame shape), ``ROW_SPACING``/``COL_SPACING`` (sensel pitch, with
its unit word: ``mm``, ``millimeters``, ``cm``, ``centimeters``, ``inches``), ``SECONDS_PER_FRAME``
(s) and ``UNITS`` (the pressure unit: ``KPa``, ``mmHg``, ``PSI``, ``N/cm2``); ``SENSOR_TYPE`` and
``START_TIME`` are kept in the metadata when present. Then one block per frame: a line
``Frame N`` (anything may follow it on the line), then ``ROWS`` lines of ``COLS`` values
separated by commas; a ``B`` marks a cell outside the sensor's outline, read as 0 kPa (counted
in the metadata ``blank_cells``). Blank lines between blocks are ignored.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..units import cm_per_unit, kpa_per_unit
from ._import_common import ImportedFrames, ImportFormatError, number, text_lines

__all__ = ["read_tekscan", "looks_like_tekscan"]

_FRAME = re.compile(r"\s*frame\b\s*(\d+)?", re.IGNORECASE)
_KEYS = ("ROWS", "COLS", "ROW_SPACING", "COL_SPACING", "SECONDS_PER_FRAME", "UNITS")


def looks_like_tekscan(head: str) -> bool:
    """Whether the first lines of a file (``head``) are a Tekscan ASCII header."""
    up = head.upper()
    return "SECONDS_PER_FRAME" in up or ("ROW_SPACING" in up and "COLS" in up)


def _header(lines: list[str], path: Path) -> tuple[dict[str, tuple[str, int]], int]:
    """The header's ``KEY -> (rest of line, line number)`` and the index of the first frame line."""
    head: dict[str, tuple[str, int]] = {}
    for i, line in enumerate(lines):
        if _FRAME.match(line):
            return head, i
        parts = line.replace(",", " ").split(None, 1)
        if parts:
            head[parts[0].rstrip(":").upper()] = (parts[1].strip() if len(parts) > 1 else "", i + 1)
    raise ImportFormatError(f"{path}: no 'Frame' line: not a Tekscan ASCII export")


def _spacing_cm(head: dict[str, tuple[str, int]], key: str, path: Path) -> float:
    text, ln = head[key]
    parts = text.split()
    v = number(parts[0] if parts else "", f"{path}:{ln}: {key}")
    try:
        factor = cm_per_unit(parts[1]) if len(parts) > 1 else 1.0  # no unit word: Tekscan writes cm by default
    except ValueError as e:
        raise ImportFormatError(f"{path}:{ln}: {key}: {e}") from None
    if v <= 0:
        raise ImportFormatError(f"{path}:{ln}: {key} must be > 0, got {text!r}")
    return v * factor


def read_tekscan(path: str | Path, *, unit: str | None = None) -> ImportedFrames:
    """Read a Tekscan ASCII export.

    Parameters
    ----------
    path : path
        The file.
    unit : str, optional
        The pressure unit, when the file has no ``UNITS`` line (or to override it).

    Returns
    -------
    ImportedFrames
        Pressure in kPa, frame ``k`` at ``k * SECONDS_PER_FRAME`` s.

    Raises
    ------
    ImportFormatError
        One line naming the file, the line and what is wrong (a missing header key, a row with
        the wrong number of values, a value that is not a number, a frame cut short).
    """
    p = Path(path)
    lines = text_lines(p)
    head, first = _header(lines, p)
    missing = [k for k in _KEYS if k not in head and not (k == "UNITS" and unit)]
    if missing:
        raise ImportFormatError(f"{p}: header lacks {', '.join(missing)} (a Tekscan ASCII export has them)")
    rows = int(number(head["ROWS"][0].split()[0] if head["ROWS"][0] else "", f"{p}:{head['ROWS'][1]}: ROWS"))
    cols = int(number(head["COLS"][0].split()[0] if head["COLS"][0] else "", f"{p}:{head['COLS'][1]}: COLS"))
    if not (1 <= rows <= 1024 and 1 <= cols <= 1024):
        raise ImportFormatError(f"{p}: ROWS {rows} and COLS {cols} must be 1 ... 1024")
    spf_text, spf_ln = head["SECONDS_PER_FRAME"]
    spf = number(spf_text.split()[0] if spf_text else "", f"{p}:{spf_ln}: SECONDS_PER_FRAME")
    if spf <= 0:
        raise ImportFormatError(f"{p}:{spf_ln}: SECONDS_PER_FRAME must be > 0, got {spf_text!r}")
    unit_name = unit or (head["UNITS"][0].split() or [""])[0]
    try:
        factor = kpa_per_unit(unit_name)
    except ValueError as e:
        ln = head["UNITS"][1] if "UNITS" in head else 0
        raise ImportFormatError(f"{p}:{ln}: UNITS: {e}") from None
    frames: list[np.ndarray] = []
    blank = 0
    i = first
    n = len(lines)
    while i < n:
        line = lines[i]
        if not line.strip():
            i += 1
            continue
        if not _FRAME.match(line):
            raise ImportFormatError(f"{p}:{i + 1}: expected 'Frame N' or a blank line, got {line.strip()[:40]!r}")
        i += 1
        block = np.empty((rows, cols), np.float64)
        for r in range(rows):
            if i >= n or not lines[i].strip() or _FRAME.match(lines[i]):
                raise ImportFormatError(f"{p}:{i + 1}: frame {len(frames) + 1} has {r} rows, ROWS says {rows}")
            cells = [c.strip() for c in lines[i].rstrip().rstrip(",").split(",")]
            if len(cells) != cols:
                raise ImportFormatError(f"{p}:{i + 1}: {len(cells)} values, COLS says {cols}")
            for c, v in enumerate(cells):
                if v.upper() == "B":
                    block[r, c] = 0.0
                    blank += 1
                else:
                    block[r, c] = number(v, f"{p}:{i + 1}")
            i += 1
        frames.append(block)
    if not frames:
        raise ImportFormatError(f"{p}: no frame")
    arr = (np.stack(frames) * factor).astype(np.float32)
    extra = {k.lower(): head[k][0] for k in ("SENSOR_TYPE", "START_TIME", "START_DATE") if k in head}
    extra["blank_cells"] = int(blank // len(frames))
    return ImportedFrames(arr, np.arange(len(frames)) * spf, _spacing_cm(head, "COL_SPACING", p),
                          _spacing_cm(head, "ROW_SPACING", p), "tekscan", unit_name, extra)
