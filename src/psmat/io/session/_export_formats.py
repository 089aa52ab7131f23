"""A session's data as a table for other programs: CSV, Parquet or MATLAB, units in every name.

:func:`export` writes one of four tables of a session (its root device; streams are not
included):

============  ==========================================================================
``what``      columns (row-major cells, ``rRRcCC``; every name ends with its unit)
============  ==========================================================================
``counts``    ``time_s``, ``valid``, ``r00c00_count`` ... (a mat; ``s00_count`` ... for the
              material DAQ, ``s0_heading_deg`` ... for the IMUs)
``pressure``  ``time_s``, ``valid``, ``r00c00_kpa`` ... (the stored product ``pressure``, kPa)
``cop``       ``time_s``, ``valid``, ``ml_cm``, ``ap_cm`` (the stored product ``cop``, cm)
``events``    ``time_s``, ``label``
============  ==========================================================================

``time_s`` is the host time of the frame (or event), s; ``valid`` is 1 for a frame that passed
its checks (0: a placeholder). Pressure and CoP are those ``psmat process`` stored in the file
(NaN on frames that were not usable); a session without them is one ValueError line saying so.

Formats: ``csv`` (UTF-8, one header line, numbers written exactly: shortest round-trip floats,
``nan`` for a missing value); ``parquet`` (pyarrow, the ``psmat[parquet]`` extra: each field's
unit in its metadata ``unit`` and all of them, as JSON, in the schema metadata ``psmat.units``);
``mat`` (MATLAB 5, :func:`scipy.io.savemat`: one variable per column stem, ``time``, ``valid``,
``ml``, ``ap``, ``label``, the cells as one ``(T, R, C)`` array named ``counts`` or
``pressure``, and a struct ``units`` giving each variable's unit). The file is written atomically
(:func:`psmat._atomic.replacing`): whole or not at all.
"""

from __future__ import annotations

import csv
import json
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._atomic import replacing
from ._layout import Session
from ._reader import load_session

WHATS = ("counts", "pressure", "cop", "events")
FORMATS = ("csv", "parquet", "mat")
#: the file name extension of each format
EXTENSIONS = {"csv": "csv", "parquet": "parquet", "mat": "mat"}
#: what the Parquet export needs when pyarrow is missing
PARQUET_HINT = "pip install psmat[parquet]"
_IMU_ANGLES = ("heading", "roll", "pitch")


@dataclass
class Table:
    """Columns (name, unit, 1-D array) and the MAT variables (stem -> (array, unit)) of one export."""

    names: list[str] = field(default_factory=list)
    units: list[str] = field(default_factory=list)
    columns: list[NDArray[Any]] = field(default_factory=list)
    mat: dict[str, tuple[NDArray[Any], str]] = field(default_factory=dict)

    def add(self, name: str, unit: str, column: NDArray[Any], stem: str | None = None) -> None:
        self.names.append(name)
        self.units.append(unit)
        self.columns.append(column)
        if stem is not None:
            self.mat[stem] = (column, unit)

    def cells(self, names: list[str], unit: str, frames: NDArray[Any], stem: str) -> None:
        """One column per cell of ``frames`` (T, ...) in row-major order, and the whole array for MAT."""
        flat = frames.reshape(frames.shape[0], -1)
        for k, name in enumerate(names):
            self.add(name, unit, flat[:, k])
        self.mat[stem] = (frames, unit)


def cell_names(kind: str, shape: tuple[int, ...], suffix: str) -> list[str]:
    """Column names of the cells of a frame, row-major: ``r00c00_kpa`` (a mat), ``s00_count`` (DAQ), ...

    Rows and columns get two digits, more when the mat has more than 100 of them.
    """
    if kind == "imu":
        return [f"s{k}_{a}_deg" for k in range(shape[0]) for a in _IMU_ANGLES[: shape[1]]]
    w = max(2, len(str(max(shape) - 1)))
    if len(shape) == 1:
        return [f"s{k:0{w}d}_{suffix}" for k in range(shape[0])]
    r, c = shape
    return [f"r{i:0{w}d}c{j:0{w}d}_{suffix}" for i in range(r) for j in range(c)]


def _product(s: Session, name: str, tail: tuple[int, ...]) -> NDArray[Any]:
    """The stored product ``name`` of shape (T, *tail), or one ValueError line naming ``psmat process``."""
    where = s.path if s.path is not None else "this session"
    p = s.products.get(name)
    if p is None:
        raise ValueError(f"no {name} in {where}: run psmat process {where} first")
    data = np.asarray(p.data)
    if data.shape != (s.n_frames, *tail):
        raise ValueError(f"{where}: the stored {name} has shape {data.shape}, the session "
                         f"{(s.n_frames, *tail)}; run psmat process {where} --overwrite")
    return data


def table(s: Session, what: str) -> Table:
    """The columns of ``what`` (module docstring) for the session ``s``."""
    if what not in WHATS:
        raise ValueError(f"what must be one of {', '.join(WHATS)}, got {what!r}")
    t = Table()
    if what == "events":
        t.add("time_s", "s", np.array([e[0] for e in s.events], np.float64), "time")
        t.add("label", "", np.array([e[1] for e in s.events], dtype=object), "label")
        return t
    t.add("time_s", "s", np.asarray(s.host_time_s, np.float64), "time")
    t.add("valid", "1", np.asarray(s.valid, bool), "valid")
    if what == "counts" and s.kind == "pressure":
        raise ValueError(f"{s.path}: an imported pressure session has no counts; export --what pressure")
    if what == "counts":
        unit, suffix = ("deg", "deg") if s.kind == "imu" else ("count", "count")
        t.cells(cell_names(s.kind, s.frame_shape, suffix), unit, s.counts, "angles" if s.kind == "imu" else "counts")
    elif what == "pressure" and s.kind == "pressure":  # imported frames: the kPa are the frames themselves
        t.cells(cell_names("psm", s.frame_shape, "kpa"), "kPa", s.frames, "pressure")
    elif what == "pressure":
        if s.kind != "psm":
            raise ValueError(f"{s.path}: a {s.kind} session has no pressure (mats only)")
        t.cells(cell_names("psm", s.frame_shape, "kpa"), "kPa", _product(s, "pressure", s.frame_shape), "pressure")
    else:
        cop = _product(s, "cop", (2,))
        t.add("ml_cm", "cm", cop[:, 0], "ml")
        t.add("ap_cm", "cm", cop[:, 1], "ap")
    return t


def _text(col: NDArray[Any]) -> list[Any]:
    if col.dtype == bool:
        return col.astype(np.uint8).tolist()
    if col.dtype.kind == "f":
        return [repr(x) for x in col.astype(np.float64).tolist()]  # shortest round-trip
    return col.tolist()


def _rows(t: Table, block: int = 4096) -> Iterator[list[Any]]:
    n = len(t.columns[0]) if t.columns else 0
    for a in range(0, n, block):
        cols = [_text(c[a:a + block]) for c in t.columns]
        yield from (list(r) for r in zip(*cols))


def _write_csv(t: Table, tmp: Path) -> None:
    with open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(t.names)
        w.writerows(_rows(t))


def _pyarrow() -> tuple[Any, Any]:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise ImportError(f"Parquet export needs pyarrow, which is not installed: {PARQUET_HINT}") from None
    return pa, pq


def _write_parquet(t: Table, tmp: Path, meta: dict[str, str]) -> None:
    pa, pq = _pyarrow()
    fields, arrays = [], []
    for name, unit, col in zip(t.names, t.units, t.columns):
        arr = pa.array(col.tolist(), type=pa.string()) if col.dtype == object else pa.array(col)
        fields.append(pa.field(name, arr.type, metadata={"unit": unit}))
        arrays.append(arr)
    schema = pa.schema(fields, metadata={"psmat.units": json.dumps(dict(zip(t.names, t.units))), **meta})
    pq.write_table(pa.Table.from_arrays(arrays, schema=schema), str(tmp))


def _write_mat(t: Table, tmp: Path) -> None:
    from scipy.io import savemat

    variables: dict[str, Any] = {}
    for stem, (arr, _unit) in t.mat.items():
        variables[stem] = arr.astype(np.uint8) if arr.dtype == bool else arr
    variables["units"] = {stem: unit for stem, (_arr, unit) in t.mat.items()}
    with open(tmp, "wb") as fh:
        savemat(fh, variables, oned_as="column", do_compression=True)


def export(session_or_path: Session | str | os.PathLike[str], what: str, fmt: str,
           out: str | os.PathLike[str]) -> Path:
    """Write one table of a session (``what``) to ``out`` in format ``fmt``; return ``out``.

    Parameters
    ----------
    session_or_path : Session or path
        A loaded session or a session file (:func:`psmat.io.load_session`).
    what : {"counts", "pressure", "cop", "events"}
        The table (module docstring): the raw frames, the stored pressure (kPa) or CoP (cm)
        products, or the events (markers).
    fmt : {"csv", "parquet", "mat"}
        CSV, Parquet (needs pyarrow: ``pip install psmat[parquet]``) or MATLAB 5 (.mat).
    out : path
        The file to write (replaced atomically if it exists; its folder must exist).

    Raises
    ------
    ValueError
        An unknown ``what`` or ``fmt``; pressure or CoP asked of a session that has not been
        processed (``no pressure in S.h5: run psmat process S.h5 first``).
    ImportError
        ``fmt="parquet"`` without pyarrow (the message names ``pip install psmat[parquet]``).
    SessionFormatError, OSError
        The session does not load; the file cannot be written.
    """
    if what not in WHATS:
        raise ValueError(f"what must be one of {', '.join(WHATS)}, got {what!r}")
    if fmt not in FORMATS:
        raise ValueError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    if fmt == "parquet":
        _pyarrow()  # before any work
    s = session_or_path if isinstance(session_or_path, Session) else load_session(session_or_path)
    t = table(s, what)
    out = Path(out)
    with replacing(out) as tmp:
        if fmt == "csv":
            _write_csv(t, tmp)
        elif fmt == "parquet":
            _write_parquet(t, tmp, {"psmat.what": what,
                                    "psmat.session": "" if s.path is None else Path(s.path).name})
        else:
            _write_mat(t, tmp)
    return out
