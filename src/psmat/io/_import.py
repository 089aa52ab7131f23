"""Another mat's file as a psmat session: :func:`import_pressure` (docs/spec.md §6).

Formats: Tekscan ASCII export (:mod:`._import_tekscan`), XSENSOR CSV export
(:mod:`._import_xsensor`), a generic CSV of one frame a line (:mod:`._import_csv`). The session
written is of kind ``"pressure"``: the frames in kPa, as the maker's software computed them.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from .._text import NotTextError, decode_text
from ._import_common import ImportedFrames, ImportFormatError, write_imported
from ._import_csv import read_csv_frames
from ._import_tekscan import looks_like_tekscan, read_tekscan
from ._import_xsensor import looks_like_xsensor, read_xsensor

__all__ = ["import_pressure", "read_pressure_file", "detect_format", "IMPORT_FORMATS", "ImportFormatError",
           "ImportedFrames"]

#: The formats :func:`import_pressure` reads (``"auto"`` picks one from the file's first lines).
IMPORT_FORMATS = ("tekscan", "xsensor", "csv")


def detect_format(path: str | os.PathLike[str]) -> str:
    """``"tekscan"``, ``"xsensor"`` or ``"csv"`` from a file's first 64 lines (a generic CSV otherwise)."""
    with open(path, "rb") as f:
        data = f.read(1 << 16)
    try:  # (a character cut at the 64 KiB mark reads as Windows-1252: the keywords are ASCII)
        head = "\n".join(decode_text(data).splitlines()[:64])
    except NotTextError:
        return "csv"  # (whose reader says that the file is not text)
    if looks_like_tekscan(head):
        return "tekscan"
    if looks_like_xsensor(head):
        return "xsensor"
    return "csv"


def read_pressure_file(path: str | os.PathLike[str], fmt: str = "auto", **opts: Any) -> ImportedFrames:
    """Read another mat's file (no session written): pressure in kPa, frame times, sensel size.

    ``opts``: ``unit`` (every format: the pressure unit when the file has none or to override it);
    for ``"csv"`` also ``shape``, ``pitch_cm``, ``rate_hz``, ``time_column`` (:func:`read_csv_frames`).
    Raises :class:`ImportFormatError` (one line) for a bad file, ValueError for a bad ``fmt``,
    OSError when the file cannot be read.
    """
    p = Path(path)
    if fmt not in ("auto", *IMPORT_FORMATS):
        raise ValueError(f"format must be auto or one of {', '.join(IMPORT_FORMATS)}, got {fmt!r}")
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no such file")
    kind = detect_format(p) if fmt == "auto" else fmt
    if kind != "csv":
        extra = sorted(k for k, v in opts.items() if k != "unit" and v is not None)
        if extra:
            raise ValueError(f"{p}: {', '.join(extra)} apply to a generic CSV only (this is {kind})")
        return (read_tekscan if kind == "tekscan" else read_xsensor)(p, unit=opts.get("unit"))
    return read_csv_frames(p, **opts)


def import_pressure(path: str | os.PathLike[str], out_h5: str | os.PathLike[str] | None = None, fmt: str = "auto",
                    *, overwrite: bool = False, **opts: Any) -> Path:
    """Import another mat's pressure file as a psmat session of kind ``"pressure"`` (docs/spec.md §6).

    Parameters
    ----------
    path : path
        A Tekscan ASCII export, an XSENSOR CSV export or a generic CSV (one frame a line).
    out_h5 : path, optional
        The session to write (default ``STEM.h5`` beside ``path``).
    fmt : {"auto", "tekscan", "xsensor", "csv"}
        The format; ``"auto"`` reads the file's first lines.
    overwrite : bool
        Replace an existing ``out_h5``.
    **opts
        ``unit``; for a generic CSV ``shape=(R, C)``, ``pitch_cm``, ``rate_hz``, ``time_column``.

    Returns
    -------
    Path
        The session written: frames ``(T, R, C)`` float32 kPa (``Session.frames``), frame times
        from 0 s on ``host_time_s``, the geometry in its profile
        (``psmat.profile.session_profile(s).geometry``), metadata ``source_format``,
        ``source_file``, ``source_unit``, ``sensel_width_cm``, ``sensel_height_cm``.

    Raises
    ------
    ImportFormatError
        A bad file (one line naming it and the line).
    ValueError, OSError, FileExistsError
        A bad option, an unreadable input, an existing output without ``overwrite``.
    """
    frames = read_pressure_file(path, fmt, **opts)
    out = Path(out_h5) if out_h5 is not None else Path(path).with_suffix(".h5")
    if out.resolve() == Path(path).resolve():
        raise ValueError(f"{out}: the output would replace the input")
    return write_imported(frames, path, out, overwrite=overwrite)
