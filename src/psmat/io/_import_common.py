"""What every importer of another mat's file returns, and how it becomes a session (docs/spec.md §6).

An importer reads a file into :class:`ImportedFrames` (pressure in kPa, frame times, sensel
size); :func:`write_imported` stores it as a session of kind ``"pressure"`` with a profile of
kind ``"pressure"`` (the geometry) and metadata saying where the frames came from.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._text import NotTextError, read_text

__all__ = ["ImportedFrames", "ImportFormatError", "write_imported", "number", "text_lines"]


class ImportFormatError(ValueError):
    """A file that is not what its format says; the message (one line) names the file and the line."""


@dataclass(eq=False)
class ImportedFrames:
    """Frames read from another mat's export.

    Attributes
    ----------
    pressure_kpa : ndarray
        ``(T, R, C)`` float32 pressure (kPa), rows and columns as the file lists them.
    t_s : ndarray
        ``(T,)`` float64 frame times (s) from the first frame (0).
    sensel_width_cm, sensel_height_cm : float
        The sensel's size along the columns (width) and along the rows (height), cm.
    source_format : str
        ``"tekscan"``, ``"xsensor"`` or ``"csv"``.
    source_unit : str
        The pressure unit the file was in (converted to kPa by :func:`psmat.units.kpa_per_unit`).
    extra : dict
        Anything else worth keeping (sensor name, start time, blank cells), stored in the metadata.
    """

    pressure_kpa: NDArray[np.float32]
    t_s: NDArray[np.float64]
    sensel_width_cm: float
    sensel_height_cm: float
    source_format: str
    source_unit: str
    extra: dict[str, Any] = field(default_factory=dict)


def text_lines(path: Path) -> list[str]:
    """The lines of another maker's export (UTF-8, UTF-16 with its byte-order mark, or Windows-1252,
    as their software and spreadsheets save it); a file that is not text is an ImportFormatError."""
    try:
        return read_text(path).splitlines()
    except NotTextError as exc:
        raise ImportFormatError(f"{path} {exc}") from None


def number(text: str, where: str) -> float:
    """``text`` as a finite float, or :class:`ImportFormatError` naming ``where``."""
    try:
        v = float(text)
    except ValueError:
        raise ImportFormatError(f"{where}: {text.strip()!r} is not a number") from None
    if not math.isfinite(v):
        raise ImportFormatError(f"{where}: {text.strip()!r} is not a finite number")
    return v


def write_imported(frames: ImportedFrames, source: str | os.PathLike[str], out_h5: str | os.PathLike[str], *,
                   overwrite: bool = False) -> Path:
    """Store imported frames as a session of kind ``"pressure"`` (docs/spec.md §6).

    Parameters
    ----------
    frames : ImportedFrames
        What an importer read.
    source : path
        The file they came from (its name goes into the metadata ``source_file``).
    out_h5 : path
        The session file to write.
    overwrite : bool
        Replace an existing ``out_h5``.

    Returns
    -------
    Path
        ``out_h5``.

    Raises
    ------
    ImportFormatError
        Sensels that are not square (psmat's geometry has one pitch), or no frame.
    """
    from .session import SessionWriter

    src = Path(source)
    p = frames.pressure_kpa
    if p.ndim != 3 or p.shape[0] < 1:
        raise ImportFormatError(f"{src}: no frame")
    w, h = float(frames.sensel_width_cm), float(frames.sensel_height_cm)
    if not (w > 0 and h > 0 and math.isfinite(w) and math.isfinite(h)):
        raise ImportFormatError(f"{src}: sensel size {w} x {h} cm is not positive")
    if abs(w - h) > 1e-6 * max(w, h):
        raise ImportFormatError(f"{src}: sensels of {w:g} x {h:g} cm are not square; psmat's mat geometry has one "
                                "pitch (docs/spec.md §5)")
    t = np.asarray(frames.t_s, np.float64)
    dt = np.diff(t)
    if t.shape != (p.shape[0],) or not np.all(np.isfinite(t)) or np.any(dt <= 0):
        raise ImportFormatError(f"{src}: frame times are not finite and increasing")
    rate = float(1.0 / np.median(dt)) if dt.size else 1.0
    R, C = int(p.shape[1]), int(p.shape[2])
    # the layout of psmat.profile.Profile.to_dict() for a profile of kind "pressure" (io sits below
    # psmat.profile in the layers, so the dict is written here; session_profile() checks it on load)
    profile = {"name": f"imported-{frames.source_format}",
               "description": f"a {R}x{C} {frames.source_format} mat, imported from {src.name}",
               "kind": "pressure", "protocol": "import", "rate_hz": rate,
               "geometry": {"shape": [R, C], "pitch_cm": w, "origin_cm": [0.0, 0.0], "x": "+columns", "y": "+rows"},
               "source": f"psmat import of {src.name}"}
    metadata = {"source_format": frames.source_format, "source_file": src.name, "source_unit": frames.source_unit,
                "sensel_width_cm": w, "sensel_height_cm": h, **frames.extra}
    device = {"kind": "pressure", "shape": [R, C], "source_format": frames.source_format, "rate": rate,
              "pitch_cm": w}
    out = Path(out_h5)
    with SessionWriter(out, (R, C), device=device, metadata=metadata, kind="pressure", profile=profile,
                       background=False, overwrite=overwrite) as wr:
        wr.append(np.ascontiguousarray(p, np.float32), t, np.ones(p.shape[0], bool))
    return out
