"""Recorded sessions: one HDF5 file per recording, crash-safe while it is written (SPEC §6).

A session holds the raw frames of one device (a pressure mat, the spine IMUs or the
material DAQ), per-frame timing and validity, the description of the device, the
calibration that was used, subject/trial metadata, the reader's error counters and any
processed products (G, g, pressure, CoP, …) with the parameters that made them.

Writing::

    with SessionWriter("s01_t1.h5", (16, 16), device={"serial": "0000A1B2", "r_o": 2200.0,
                       "v_ref": 3.3, "bits": 12, "fw": "0.1.0", "protocol": 2, "rate": 100},
                       metadata={"subject": "S01", "trial": 1}) as w:
        for frames, t, valid, seq, t_us in reader:         # e.g. from a reader thread
            w.append(frames, t, valid, seq=seq, device_time_us=t_us)
        w.set_counters(dropped_frames=reader.dropped)
    s = load_session("s01_t1.h5")

On-disk layout (format ``psmat-session``, version 1)
=====================================================

Plain HDF5 (superblock v3, ``libver="latest"``): any HDF5 reader (h5py, MATLAB ``h5read``,
R ``rhdf5``, HDFView, ``h5dump``) reads it; no pickles, no compound types, no enums.
``T`` is the number of frames; the time axis is always the first one, chunked
(``chunk_frames`` frames per chunk) and resizable (``maxshape=None``). Every dataset has a
string attribute ``unit``.

==================  ==================  =========  =======  ==============================================
dataset             shape               dtype      unit     content
==================  ==================  =========  =======  ==============================================
``/counts``         (T, R, C) psm       uint16     count    raw ADC counts of the mat, row-major cells
                    (T, 10) daq                             material-DAQ 10-bit counts, one column per sensor
``/angles``         (T, 5, 3) imu       float32    deg      Euler angles (heading, roll, pitch) per IMU
``/host_time_s``    (T,)                float64    s        host clock when the frame was received
``/valid``          (T,)                uint8      1        1 = frame passed its checksum/CRC, 0 = kept
                                                            as a placeholder (values meaningless)
``/seq``            (T,)                int64      1        device frame sequence number (unwrapped,
                                                            protocol v2); -1 = unknown (protocol v1)
``/device_time_us`` (T,)                int64      us       device clock (unwrapped ``t_us``); -1 = unknown
``/committed``      (1,)                int64      frame    frames known complete in this file (written
                                                            after each flush: readers of an unfinished
                                                            file trust only this many rows)
``/counters``       (4,)                int64      1        reader error counters, names in the attribute
                                                            ``names``: dropped_frames, bad_frames,
                                                            resyncs, bytes_discarded
``/products/NAME``  any                 any        any      processed product (e.g. G, g, pressure, cop)
==================  ==================  =========  =======  ==============================================

Attributes of ``/`` (the root group): ``format`` = ``"psmat-session"``, ``format_version``
(int), ``kind`` (``"psm"``, ``"imu"`` or ``"daq"``), ``frame_shape`` (int array),
``frame_dataset`` (``"counts"`` or ``"angles"``), ``created_utc`` (ISO 8601),
``psmat_version``; set when the writer closes cleanly: ``complete`` (1), ``n_frames``,
``closed_utc``. A file without ``complete = 1`` is an interrupted recording.

Groups ``/device``, ``/calibration`` (only when one was used) and ``/metadata``: the
attribute ``json`` holds the whole dictionary as a JSON string (the authoritative copy);
every scalar, string or flat numeric-list entry is also an attribute of its own, so that
``h5dump -A`` shows e.g. ``/device`` ``serial``, ``r_o``, ``v_ref``, ``bits``, ``fw``,
``protocol``, ``rate``, ``shape``.

Each ``/products/NAME`` dataset has attributes ``unit``, ``params_json`` (the parameters
that made it, JSON), the scalar parameters as attributes of their own, and ``created_utc``.

Crash safety
============

A recording must survive its writer being killed (SIGKILL, a crash, a pulled cable that
takes the process down). Two mechanisms, each enough on its own for a killed process:

1. **HDF5 in SWMR mode.** All objects are created first, then the file switches to
   single-writer/multiple-reader mode; each flush writes the new rows, flushes, then
   raises ``/committed`` and flushes again. SWMR orders the metadata writes so that the
   file on disk is always a consistent HDF5 file. An interrupted file keeps HDF5's
   "open for writing" flag: non-SWMR readers refuse it (``h5clear -s FILE`` clears the flag);
   h5py reads it with ``h5py.File(path, "r", swmr=True)`` and :func:`load_session` does
   that by itself, keeping only ``/committed`` rows.
2. **An append-only journal** ``PATH.journal`` beside the file: a JSON header, then one
   fixed-size binary record per frame, written with ``os.write`` *before* :meth:`append`
   returns (so it is in the operating system's cache and survives the process being
   killed) and ``fsync``'d at each flush (so it survives a power cut up to the last
   flush). :func:`load_session` reads the longest CRC-valid prefix of the journal and
   uses it when it holds more frames than the HDF5 file (or when the HDF5 file is
   unreadable); :func:`repair_session` rewrites a clean file from it. :meth:`SessionWriter.close`
   removes the journal once the HDF5 file is complete and synced.

Journal format (little-endian): ``b"PSMATJ01"``, ``uint32`` header length ``H``, ``H`` bytes
of UTF-8 JSON (kind, frame shape and dtype, device, calibration, metadata, record size),
then records of ``32 + P + 4`` bytes: ``uint8 type`` (0 frame, 1 counters), ``uint8 valid``,
6 pad bytes, ``float64 host_time_s``, ``int64 seq``, ``int64 device_time_us``, ``P``
payload bytes (the frame, or the counters as int64, zero padded), ``uint32`` CRC-32 of the
record's preceding bytes.
"""

from __future__ import annotations

import csv
import datetime as _dt
import json
import math
import os
import threading
import time
import zlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "COUNTER_NAMES",
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "Product",
    "Session",
    "SessionFormatError",
    "SessionWriter",
    "export_csv",
    "info",
    "journal_path",
    "load_session",
    "repair_session",
    "save_product",
]

FORMAT_NAME = "psmat-session"
FORMAT_VERSION = 1
COUNTER_NAMES: tuple[str, ...] = ("dropped_frames", "bad_frames", "resyncs", "bytes_discarded")

_KINDS: dict[str, dict[str, Any]] = {
    # kind: frame dataset, dtype, unit, default frame shape
    "psm": {"dataset": "counts", "dtype": np.dtype("<u2"), "unit": "count", "shape": (16, 16)},
    "imu": {"dataset": "angles", "dtype": np.dtype("<f4"), "unit": "deg", "shape": (5, 3)},
    "daq": {"dataset": "counts", "dtype": np.dtype("<u2"), "unit": "count", "shape": (10,)},
}
_PER_FRAME = ("host_time_s", "valid", "seq", "device_time_us")
_IMU_ANGLES = ("heading", "roll", "pitch")

_J_MAGIC = b"PSMATJ01"
_J_FRAME, _J_COUNTERS = 0, 1


class SessionFormatError(ValueError):
    """A file is not a (readable) psmat session; the message names the file and the problem."""


def journal_path(path: str | os.PathLike[str]) -> Path:
    """The journal side file of a session file: ``PATH.journal``."""
    p = Path(path)
    return p.with_name(p.name + ".journal")


def _utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="milliseconds")


def _psmat_version() -> str:
    try:
        from importlib.metadata import version

        return version("psmat")
    except Exception:  # noqa: BLE001 - not installed (source checkout)
        try:
            import psmat

            return str(getattr(psmat, "__version__", "unknown"))
        except Exception:  # noqa: BLE001
            return "unknown"


def _json_default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, (Path, os.PathLike)):
        return os.fspath(o)
    if hasattr(o, "to_dict"):
        return o.to_dict()
    raise TypeError(f"{type(o).__name__} is not JSON serialisable")


def _to_json(d: Any) -> str:
    return json.dumps(d, default=_json_default, allow_nan=True, sort_keys=False)


def _as_dict(d: Any, what: str) -> dict[str, Any] | None:
    if d is None:
        return None
    if hasattr(d, "to_dict") and not isinstance(d, Mapping):
        d = d.to_dict()
    if not isinstance(d, Mapping):
        raise TypeError(f"{what} must be a dict (or have .to_dict()), got {type(d).__name__}")
    out = json.loads(_to_json(dict(d)))  # normalise: plain JSON types, checks serialisability
    return out


def _set_flat_attrs(obj: h5py.HLObject, d: Mapping[str, Any]) -> None:
    """``json`` = the whole dict, plus one attribute per scalar / flat list entry."""
    obj.attrs["json"] = _to_json(dict(d))
    for k, v in d.items():
        if k == "json" or not isinstance(k, str) or not k:
            continue
        if isinstance(v, bool):
            obj.attrs[k] = np.uint8(v)
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            if isinstance(v, int) and not (-(2**63) <= v < 2**63):
                continue
            obj.attrs[k] = v
        elif isinstance(v, str):
            obj.attrs[k] = v
        elif isinstance(v, (list, tuple)) and v:
            if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
                arr = np.asarray(v)
                if arr.dtype.kind in "if":
                    obj.attrs[k] = arr
            elif all(isinstance(x, str) for x in v):
                obj.attrs[k] = list(v)


def _attr_str(v: Any) -> str:
    if isinstance(v, bytes):
        return v.decode("utf-8")
    if isinstance(v, np.ndarray) and v.shape == ():
        return _attr_str(v.item())
    return str(v)


# ====================================================================== data classes
@dataclass(eq=False)
class Product:
    """A processed product stored with a session: the array, its unit and the parameters that made it."""

    data: NDArray[Any]
    unit: str
    params: dict[str, Any] = field(default_factory=dict)
    created_utc: str = ""


@dataclass(eq=False)
class Session:
    """A recorded session as loaded by :func:`load_session`.

    Attributes
    ----------
    counts : ndarray
        The raw frames, time first: ``(T, R, C)`` uint16 ADC counts (``kind="psm"``),
        ``(T, 5, 3)`` float32 Euler angles in degrees (``"imu"``), ``(T, 10)`` uint16
        counts (``"daq"``). Also available as :attr:`frames`.
    host_time_s, valid : ndarray
        ``(T,)`` float64 host receive times (s) and bool validity.
    seq, device_time_us : ndarray or None
        ``(T,)`` int64 device sequence numbers / device clock (µs), -1 where unknown;
        None when the device never sent them (protocol v1).
    device, calibration, metadata : dict
        Device description, calibration used (None if none), subject/trial metadata.
    products : dict[str, Product]
    counters : dict[str, int]
        Reader error counters (:data:`COUNTER_NAMES`).
    kind : str
    complete : bool
        False for an interrupted recording (writer killed before :meth:`SessionWriter.close`).
    recovered : bool
        True when frames were recovered from the journal side file.
    notes : list[str]
        What the loader had to do (e.g. recovery), for the record.
    """

    path: Path | None
    kind: str
    counts: NDArray[Any]
    host_time_s: NDArray[np.float64]
    valid: NDArray[np.bool_]
    seq: NDArray[np.int64] | None
    device_time_us: NDArray[np.int64] | None
    device: dict[str, Any]
    calibration: dict[str, Any] | None
    metadata: dict[str, Any]
    products: dict[str, Product] = field(default_factory=dict)
    counters: dict[str, int] = field(default_factory=dict)
    format_version: int = FORMAT_VERSION
    created_utc: str = ""
    complete: bool = True
    recovered: bool = False
    notes: list[str] = field(default_factory=list)

    @property
    def frames(self) -> NDArray[Any]:
        return self.counts

    @property
    def n_frames(self) -> int:
        return int(self.counts.shape[0])

    @property
    def frame_shape(self) -> tuple[int, ...]:
        return tuple(int(x) for x in self.counts.shape[1:])

    @property
    def duration_s(self) -> float:
        t = self.host_time_s
        return float(t[-1] - t[0]) if t.size >= 2 else 0.0

    @property
    def rate_hz(self) -> float:
        """Frame rate estimated from the host times: ``(T - 1) / (t_last - t_first)``; NaN if undefined."""
        d = self.duration_s
        return (self.n_frames - 1) / d if self.n_frames >= 2 and d > 0 else math.nan

    def __repr__(self) -> str:
        return (
            f"Session(kind={self.kind!r}, frames={self.n_frames}, shape={self.frame_shape}, "
            f"duration_s={self.duration_s:.3f}, products={sorted(self.products)}, path={str(self.path)!r})"
        )


# ====================================================================== journal
def _journal_dtype(payload: int) -> np.dtype:
    return np.dtype(
        [
            ("type", "u1"),
            ("valid", "u1"),
            ("pad", "u1", (6,)),
            ("host_time_s", "<f8"),
            ("seq", "<i8"),
            ("device_time_us", "<i8"),
            ("payload", "u1", (payload,)),
            ("crc", "<u4"),
        ]
    )


def _fill_crc(rec: NDArray[Any]) -> bytes:
    raw = rec.view(np.uint8).reshape(rec.shape[0], rec.dtype.itemsize)
    for i in range(rec.shape[0]):
        rec["crc"][i] = zlib.crc32(raw[i, :-4].tobytes())
    return rec.tobytes()


def _write_all(fd: int, data: bytes) -> None:
    mv = memoryview(data)
    while mv:
        n = os.write(fd, mv)
        mv = mv[n:]


@dataclass
class _JournalContents:
    header: dict[str, Any]
    frames: NDArray[Any]
    host_time_s: NDArray[np.float64]
    valid: NDArray[np.bool_]
    seq: NDArray[np.int64]
    device_time_us: NDArray[np.int64]
    counters: dict[str, int] | None
    n_bad_tail_bytes: int


def _read_journal(jpath: Path) -> _JournalContents:
    raw = jpath.read_bytes()
    if len(raw) < 12 or raw[:8] != _J_MAGIC:
        raise SessionFormatError(f"{jpath}: not a psmat session journal (bad or missing magic)")
    hlen = int.from_bytes(raw[8:12], "little")
    if 12 + hlen > len(raw):
        raise SessionFormatError(f"{jpath}: journal header truncated ({len(raw) - 12} of {hlen} bytes)")
    try:
        header = json.loads(raw[12 : 12 + hlen].decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise SessionFormatError(f"{jpath}: journal header is not valid JSON ({e})") from None
    dt = _journal_dtype(int(header["payload_bytes"]))
    if dt.itemsize != int(header["record_bytes"]):
        raise SessionFormatError(f"{jpath}: record size mismatch in journal header")
    body = raw[12 + hlen :]
    n = len(body) // dt.itemsize
    rec = np.frombuffer(body[: n * dt.itemsize], dtype=dt)
    u8 = rec.view(np.uint8).reshape(n, dt.itemsize) if n else np.zeros((0, dt.itemsize), np.uint8)
    good = 0
    for i in range(n):
        if zlib.crc32(u8[i, :-4].tobytes()) != int(rec["crc"][i]):
            break
        good += 1
    rec = rec[:good]
    bad_tail = len(body) - good * dt.itemsize
    fshape = tuple(int(x) for x in header["frame_shape"])
    fdtype = np.dtype(header["frame_dtype"])
    nbytes = int(np.prod(fshape)) * fdtype.itemsize
    is_frame = rec["type"] == _J_FRAME
    fr = rec[is_frame]
    frames = fr["payload"][:, :nbytes].copy().view(fdtype).reshape((fr.shape[0], *fshape))
    counters = None
    cr = rec[rec["type"] == _J_COUNTERS]
    if cr.shape[0]:
        vals = cr["payload"][-1, : 8 * len(COUNTER_NAMES)].copy().view("<i8")
        counters = {k: int(v) for k, v in zip(COUNTER_NAMES, vals)}
    return _JournalContents(
        header=header,
        frames=frames,
        host_time_s=fr["host_time_s"].astype(np.float64),
        valid=fr["valid"].astype(bool),
        seq=fr["seq"].astype(np.int64),
        device_time_us=fr["device_time_us"].astype(np.int64),
        counters=counters,
        n_bad_tail_bytes=bad_tail,
    )


# ====================================================================== writer
class SessionWriter:
    """Write a session to ``path`` (HDF5, SWMR) with a crash-safety journal; use as a context manager.

    Parameters
    ----------
    path : str or Path
        The ``.h5`` file to create. An existing file (or journal) is an error unless
        ``overwrite=True``.
    shape : tuple of int
        Frame shape: ``(R, C)`` for ``kind="psm"``, ``(5, 3)`` for ``"imu"`` (sensors ×
        heading/roll/pitch), ``(10,)`` (or ``10``) for ``"daq"``.
    device : dict
        Device description (serial, r_o, v_ref, bits, fw, protocol, rate, …; e.g. the
        parsed IDENTIFY reply). ``shape`` and ``kind`` are added if missing.
    calibration : dict or object with ``to_dict()``, optional
        The calibration used (e.g. :class:`psmat.Calibration`).
    metadata : dict, optional
        Subject/trial metadata (subject id, trial, condition, operator, notes, …).
    kind : {"psm", "imu", "daq"}
    chunk_frames : int
        Frames per HDF5 chunk along time.
    flush_interval_s, flush_frames : float, int
        Buffered frames go to the HDF5 file (and the journal is fsync'd) when either this
        much time has passed since the last flush or this many frames are pending.
    background : bool
        True (default): flushing happens on a writer thread, so :meth:`append` only copies
        the batch and writes its journal records (microseconds) — safe to call from a
        serial reader thread at 165 Hz. False: :meth:`append` flushes inline when due.
    overwrite : bool

    Thread safety: :meth:`append`, :meth:`set_counters` and :meth:`flush` may be called from
    any thread (calls are serialised internally); frames are stored in call order.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        shape: int | tuple[int, ...],
        device: Mapping[str, Any],
        calibration: Any = None,
        metadata: Mapping[str, Any] | None = None,
        kind: str = "psm",
        chunk_frames: int = 256,
        *,
        flush_interval_s: float = 0.5,
        flush_frames: int = 512,
        background: bool = True,
        overwrite: bool = False,
    ) -> None:
        if kind not in _KINDS:
            raise ValueError(f"kind must be one of {sorted(_KINDS)}, got {kind!r}")
        spec = _KINDS[kind]
        fshape = (int(shape),) if isinstance(shape, (int, np.integer)) else tuple(int(x) for x in shape)
        if kind == "psm" and len(fshape) != 2:
            raise ValueError(f"a psm frame shape is (R, C), got {fshape}")
        if kind == "imu" and (len(fshape) != 2 or fshape[1] != 3):
            raise ValueError(f"an imu frame shape is (n_sensors, 3), got {fshape}")
        if kind == "daq" and len(fshape) != 1:
            raise ValueError(f"a daq frame shape is (n_sensors,), got {fshape}")
        if any(x < 1 for x in fshape):
            raise ValueError(f"frame shape must be positive, got {fshape}")
        if chunk_frames < 1 or flush_frames < 1 or not flush_interval_s > 0:
            raise ValueError("chunk_frames and flush_frames must be >= 1 and flush_interval_s > 0")
        self.path = Path(path)
        self.kind = kind
        self.frame_shape = fshape
        self.frame_dtype: np.dtype = spec["dtype"]
        self._dset_name: str = spec["dataset"]
        self.flush_interval_s = float(flush_interval_s)
        self.flush_frames = int(flush_frames)
        dev = _as_dict(device, "device") or {}
        dev.setdefault("kind", kind)
        dev.setdefault("shape", list(fshape))
        self.device = dev
        self.calibration = _as_dict(calibration, "calibration")
        self.metadata = _as_dict(metadata, "metadata") or {}
        self.jpath = journal_path(self.path)
        for p in (self.path, self.jpath):
            if p.exists() and not overwrite:
                raise FileExistsError(f"{p} exists (pass overwrite=True to replace it)")
        if overwrite:
            for p in (self.path, self.jpath):
                if p.exists():
                    p.unlink()

        self._n_written = 0  # frames in the HDF5 file
        self._n_appended = 0
        self._pending: list[tuple[NDArray[Any], ...]] = []
        self._pending_frames = 0
        self._counters = dict.fromkeys(COUNTER_NAMES, 0)
        self._counters_dirty = False
        self._last_flush = time.monotonic()
        self._buf_lock = threading.Lock()  # pending list + journal fd
        self._h5_lock = threading.Lock()  # HDF5 file
        self._error: BaseException | None = None
        self._closed = False
        self.created_utc = _utc_now()

        # --- HDF5: every object first, then SWMR
        f = h5py.File(self.path, "w", libver="latest")
        try:
            self._create_layout(f, int(chunk_frames))
            f.flush()
            f.swmr_mode = True
        except BaseException:
            f.close()
            raise
        self._f = f
        self._d = {name: f[name] for name in (self._dset_name, *_PER_FRAME)}
        self._committed = f["committed"]
        self._counters_ds = f["counters"]

        # --- journal
        payload = max(int(np.prod(fshape)) * self.frame_dtype.itemsize, 8 * len(COUNTER_NAMES))
        self._jdtype = _journal_dtype(payload)
        self._payload_frame_bytes = int(np.prod(fshape)) * self.frame_dtype.itemsize
        header = {
            "format": FORMAT_NAME + "-journal",
            "format_version": FORMAT_VERSION,
            "kind": kind,
            "frame_shape": list(fshape),
            "frame_dtype": self.frame_dtype.str,
            "payload_bytes": payload,
            "record_bytes": self._jdtype.itemsize,
            "counter_names": list(COUNTER_NAMES),
            "device": self.device,
            "calibration": self.calibration,
            "metadata": self.metadata,
            "created_utc": self.created_utc,
        }
        hb = _to_json(header).encode("utf-8")
        self._jfd = os.open(self.jpath, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_APPEND, 0o644)
        _write_all(self._jfd, _J_MAGIC + len(hb).to_bytes(4, "little") + hb)
        os.fsync(self._jfd)
        _fsync_dir(self.path.parent)

        self._background = bool(background)
        self._wake = threading.Event()
        self._stop = False
        self._thread: threading.Thread | None = None
        if self._background:
            self._thread = threading.Thread(target=self._run, name=f"SessionWriter({self.path.name})", daemon=True)
            self._thread.start()

    # ------------------------------------------------------------------ layout
    def _create_layout(self, f: h5py.File, chunk: int) -> None:
        spec = _KINDS[self.kind]
        a = f.attrs
        a["format"] = FORMAT_NAME
        a["format_version"] = FORMAT_VERSION
        a["kind"] = self.kind
        a["frame_shape"] = np.asarray(self.frame_shape, dtype=np.int64)
        a["frame_dataset"] = self._dset_name
        a["created_utc"] = self.created_utc
        a["psmat_version"] = _psmat_version()
        d = f.create_dataset(
            self._dset_name,
            shape=(0, *self.frame_shape),
            maxshape=(None, *self.frame_shape),
            dtype=self.frame_dtype,
            chunks=(chunk, *self.frame_shape),
        )
        d.attrs["unit"] = spec["unit"]
        d.attrs["axes"] = {
            "psm": "time, row, column",
            "imu": "time, sensor, (heading, roll, pitch)",
            "daq": "time, sensor",
        }[self.kind]
        tchunk = max(chunk, 1024)
        for name, dt, unit, desc in (
            ("host_time_s", "<f8", "s", "host clock when the frame was received"),
            ("valid", "u1", "1", "1 = frame passed its checksum/CRC; 0 = placeholder"),
            ("seq", "<i8", "1", "device frame sequence number (unwrapped); -1 = unknown"),
            ("device_time_us", "<i8", "us", "device clock (unwrapped); -1 = unknown"),
        ):
            ds = f.create_dataset(name, shape=(0,), maxshape=(None,), dtype=dt, chunks=(tchunk,))
            ds.attrs["unit"] = unit
            ds.attrs["description"] = desc
        c = f.create_dataset("committed", data=np.zeros(1, np.int64))
        c.attrs["unit"] = "frame"
        c.attrs["description"] = "rows known complete (raised after each flush)"
        k = f.create_dataset("counters", data=np.zeros(len(COUNTER_NAMES), np.int64))
        k.attrs["unit"] = "1"
        k.attrs["names"] = list(COUNTER_NAMES)
        _set_flat_attrs(f.create_group("device"), self.device)
        if self.calibration is not None:
            _set_flat_attrs(f.create_group("calibration"), self.calibration)
        _set_flat_attrs(f.create_group("metadata"), self.metadata)
        f.create_group("products")

    # ------------------------------------------------------------------ public API
    def __enter__(self) -> SessionWriter:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    @property
    def n_frames(self) -> int:
        """Frames appended so far."""
        return self._n_appended

    def append(
        self,
        frames: ArrayLike,
        host_time_s: ArrayLike,
        valid: ArrayLike,
        seq: ArrayLike | None = None,
        device_time_us: ArrayLike | None = None,
    ) -> None:
        """Append a batch of ``N`` frames (or one frame without the batch axis).

        ``frames``: ``(N, *shape)`` — uint16-range integers for psm/daq, degrees for imu.
        ``host_time_s``, ``valid``: ``(N,)`` (or scalars for one frame). ``seq``,
        ``device_time_us``: ``(N,)`` integers or None (stored as -1). When this returns, the
        batch is in the journal (it survives the process being killed); it reaches the
        HDF5 file at the next flush.
        """
        self._check_usable()
        fr = np.asarray(frames)
        if fr.shape == self.frame_shape:
            fr = fr[None]
        if fr.shape[1:] != self.frame_shape:
            raise ValueError(f"frames must have shape (N, {', '.join(map(str, self.frame_shape))}), got {fr.shape}")
        n = fr.shape[0]
        if self.frame_dtype.kind == "u":
            if fr.dtype.kind not in "ui" and not (fr.dtype.kind == "f" and np.all(fr == np.round(fr))):
                raise TypeError(f"{self.kind} frames must be integer counts, got dtype {fr.dtype}")
            if n and (fr.min() < 0 or fr.max() > np.iinfo(self.frame_dtype).max):
                raise ValueError(f"{self.kind} counts out of uint16 range")
        elif fr.dtype.kind not in "uif":
            raise TypeError(f"{self.kind} frames must be real numbers, got dtype {fr.dtype}")
        fr = np.ascontiguousarray(fr, dtype=self.frame_dtype)
        t = _per_frame(host_time_s, n, np.float64, "host_time_s")
        v = _per_frame(valid, n, np.bool_, "valid")
        s = np.full(n, -1, np.int64) if seq is None else _per_frame(seq, n, np.int64, "seq")
        dt = np.full(n, -1, np.int64) if device_time_us is None else _per_frame(device_time_us, n, np.int64, "device_time_us")
        if n == 0:
            return
        rec = np.zeros(n, self._jdtype)
        rec["type"] = _J_FRAME
        rec["valid"] = v
        rec["host_time_s"] = t
        rec["seq"] = s
        rec["device_time_us"] = dt
        rec["payload"][:, : self._payload_frame_bytes] = fr.reshape(n, -1).view(np.uint8)
        blob = _fill_crc(rec)
        due = False
        with self._buf_lock:
            if self._closed:
                raise ValueError(f"{self.path}: writer is closed")
            _write_all(self._jfd, blob)
            self._pending.append((fr, t, v.astype(np.uint8), s, dt))
            self._pending_frames += n
            self._n_appended += n
            due = (
                self._pending_frames >= self.flush_frames
                or time.monotonic() - self._last_flush >= self.flush_interval_s
            )
        if due:
            if self._background:
                self._wake.set()
            else:
                self._drain()

    def set_counters(self, **counters: int) -> None:
        """Record the reader's error counters (cumulative values), e.g. ``dropped_frames=3``.

        Names: :data:`COUNTER_NAMES`. Stored at the next flush (and in the journal now).
        """
        self._check_usable()
        bad = set(counters) - set(COUNTER_NAMES)
        if bad:
            raise ValueError(f"unknown counter(s) {sorted(bad)}; known: {list(COUNTER_NAMES)}")
        with self._buf_lock:
            for k, val in counters.items():
                iv = int(val)
                if iv < 0:
                    raise ValueError(f"counter {k} must be >= 0, got {val}")
                self._counters[k] = iv
            self._counters_dirty = True
            rec = np.zeros(1, self._jdtype)
            rec["type"] = _J_COUNTERS
            rec["payload"][0, : 8 * len(COUNTER_NAMES)] = np.array(
                [self._counters[k] for k in COUNTER_NAMES], "<i8"
            ).view(np.uint8)
            _write_all(self._jfd, _fill_crc(rec))

    @property
    def counters(self) -> dict[str, int]:
        with self._buf_lock:
            return dict(self._counters)

    def flush(self) -> None:
        """Write every pending frame to the HDF5 file, flush it and fsync the journal (blocking)."""
        self._check_usable()
        self._drain()
        self._raise_error()

    def close(self) -> None:
        """Flush, mark the file complete, sync it and remove the journal. Idempotent."""
        if self._closed:
            return
        err: BaseException | None = None
        if self._thread is not None:
            self._stop = True
            self._wake.set()
            self._thread.join()
        try:
            self._drain()
        except BaseException as e:  # noqa: BLE001 - keep the journal, re-raise below
            err = e
        with self._buf_lock:
            self._closed = True
        err = err or self._error
        try:
            self._f.close()
        except BaseException as e:  # noqa: BLE001
            err = err or e
        if err is None:
            try:
                with h5py.File(self.path, "r+") as f:
                    f.attrs["complete"] = np.uint8(1)
                    f.attrs["n_frames"] = np.int64(self._n_written)
                    f.attrs["closed_utc"] = _utc_now()
                _fsync_file(self.path)
            except BaseException as e:  # noqa: BLE001
                err = e
        os.close(self._jfd)
        if err is not None:
            raise RuntimeError(
                f"{self.path}: the session could not be completed ({err}); the journal "
                f"{self.jpath} was kept — load_session() recovers it"
            ) from err
        self.jpath.unlink()
        _fsync_dir(self.path.parent)

    # ------------------------------------------------------------------ internals
    def _check_usable(self) -> None:
        if self._closed:
            raise ValueError(f"{self.path}: writer is closed")
        self._raise_error()

    def _raise_error(self) -> None:
        if self._error is not None:
            raise RuntimeError(f"{self.path}: background flush failed: {self._error}") from self._error

    def _run(self) -> None:
        while True:
            self._wake.wait(self.flush_interval_s)
            self._wake.clear()
            try:
                self._drain()
            except BaseException as e:  # noqa: BLE001 - surfaced by the next call
                self._error = e
                return
            if self._stop:
                return

    def _drain(self) -> None:
        with self._h5_lock:
            with self._buf_lock:
                batch, self._pending, self._pending_frames = self._pending, [], 0
                counters = dict(self._counters) if self._counters_dirty else None
                self._counters_dirty = False
                self._last_flush = time.monotonic()
            if not batch and counters is None:
                return
            if batch:
                cols = [np.concatenate([b[i] for b in batch]) for i in range(5)]
                n0, n = self._n_written, cols[0].shape[0]
                for name, arr in zip((self._dset_name, *_PER_FRAME), cols):
                    ds = self._d[name]
                    ds.resize(n0 + n, axis=0)
                    ds[n0 : n0 + n] = arr
                self._f.flush()
                self._n_written = n0 + n
            if counters is not None:
                self._counters_ds[:] = np.array([counters[k] for k in COUNTER_NAMES], np.int64)
            self._committed[0] = self._n_written
            self._f.flush()
            os.fsync(self._jfd)


def _per_frame(x: ArrayLike, n: int, dtype: Any, what: str) -> NDArray[Any]:
    a = np.asarray(x)
    if a.ndim == 0:
        a = np.full(n, a)
    if a.shape != (n,):
        raise ValueError(f"{what} must have shape ({n},), got {a.shape}")
    if np.dtype(dtype).kind == "i" and a.dtype.kind not in "ui" and a.size:
        if a.dtype.kind != "f" or not np.all(a == np.round(a)):
            raise TypeError(f"{what} must be integers, got dtype {a.dtype}")
    return a.astype(dtype)


def _fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


# ====================================================================== reading
def _superblock_eoa(path: Path) -> int | None:
    """End-of-allocation address recorded in a version 2/3 superblock at offset 0 (None if not found)."""
    with open(path, "rb") as fh:
        head = fh.read(48)
    if len(head) < 48 or head[:8] != b"\x89HDF\r\n\x1a\n" or head[8] not in (2, 3) or head[9] != 8:
        return None
    return int.from_bytes(head[28:36], "little")


def _open_h5(path: Path) -> tuple[h5py.File, bool]:
    """Open read-only; an unfinished SWMR file (consistency flag set) is opened with ``swmr=True``."""
    try:
        return h5py.File(path, "r"), False
    except OSError as first:
        # Only the "still open for writing" flag of an interrupted SWMR writer justifies a
        # SWMR open; a SWMR reader retries unreadable metadata for a long time, so a
        # damaged file (truncated, bad checksums) must fail here instead.
        if "already open for write" not in str(first) and "consistency flags" not in str(first):
            raise
        eoa = _superblock_eoa(path)
        size = path.stat().st_size
        if eoa is not None and size < eoa:
            raise OSError(f"interrupted file is truncated: {size} bytes, the superblock records {eoa}") from None
        try:
            return h5py.File(path, "r", swmr=True), True
        except OSError:
            raise first from None


def _read_group_json(f: h5py.File, name: str, path: Path) -> dict[str, Any] | None:
    if name not in f:
        return None
    g = f[name]
    if "json" not in g.attrs:
        return {k: _attr_value(v) for k, v in g.attrs.items()}
    try:
        return json.loads(_attr_str(g.attrs["json"]))
    except json.JSONDecodeError as e:
        raise SessionFormatError(f"{path}: /{name} attribute 'json' is not valid JSON ({e})") from None


def _attr_value(v: Any) -> Any:
    if isinstance(v, bytes):
        return v.decode("utf-8")
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    return v


def _read_products(f: h5py.File, path: Path) -> dict[str, Product]:
    out: dict[str, Product] = {}
    if "products" not in f:
        return out
    for name, ds in f["products"].items():
        if not isinstance(ds, h5py.Dataset):
            continue
        try:
            params = json.loads(_attr_str(ds.attrs.get("params_json", "{}")))
        except json.JSONDecodeError as e:
            raise SessionFormatError(f"{path}: product {name!r} has invalid params_json ({e})") from None
        out[name] = Product(
            data=ds[()],
            unit=_attr_str(ds.attrs.get("unit", "")),
            params=params,
            created_utc=_attr_str(ds.attrs.get("created_utc", "")),
        )
    return out


def _session_from_journal(path: Path, j: _JournalContents, notes: list[str]) -> Session:
    h = j.header
    return _make_session(
        path,
        kind=h["kind"],
        frames=j.frames,
        t=j.host_time_s,
        valid=j.valid,
        seq=j.seq,
        dt=j.device_time_us,
        device=h.get("device") or {},
        calibration=h.get("calibration"),
        metadata=h.get("metadata") or {},
        products={},
        counters=j.counters or dict.fromkeys(COUNTER_NAMES, 0),
        version=int(h.get("format_version", FORMAT_VERSION)),
        created=str(h.get("created_utc", "")),
        complete=False,
        recovered=True,
        notes=notes,
    )


def _make_session(path: Path | None, *, kind: str, frames: Any, t: Any, valid: Any, seq: Any, dt: Any,
                  device: dict[str, Any], calibration: dict[str, Any] | None, metadata: dict[str, Any],
                  products: dict[str, Product], counters: dict[str, int], version: int, created: str,
                  complete: bool, recovered: bool, notes: list[str]) -> Session:
    seq = np.asarray(seq, np.int64)
    dt = np.asarray(dt, np.int64)
    return Session(
        path=path,
        kind=kind,
        counts=np.asarray(frames),
        host_time_s=np.asarray(t, np.float64),
        valid=np.asarray(valid).astype(bool),
        seq=seq if np.any(seq >= 0) else None,
        device_time_us=dt if np.any(dt >= 0) else None,
        device=device,
        calibration=calibration,
        metadata=metadata,
        products=products,
        counters=counters,
        format_version=version,
        created_utc=created,
        complete=complete,
        recovered=recovered,
        notes=notes,
    )


def load_session(path: str | os.PathLike[str], *, use_journal: bool = True) -> Session:
    """Load a session file (complete, or interrupted: recovered from SWMR state and the journal).

    Raises
    ------
    FileNotFoundError
        Neither the file nor its journal exists.
    SessionFormatError
        Not an HDF5 file, an HDF5 file that is not a psmat session, a newer format
        version, or a corrupt file; the message names the file and the problem.
    """
    path = Path(path)
    jpath = journal_path(path)
    have_j = use_journal and jpath.is_file()
    if not path.exists() and not have_j:
        raise FileNotFoundError(f"session file not found: {path}")
    if path.exists() and not path.is_file():
        raise SessionFormatError(f"{path}: not a regular file")
    notes: list[str] = []

    journal: _JournalContents | None = None
    jerr: str | None = None
    if have_j:
        try:
            journal = _read_journal(jpath)
        except (SessionFormatError, KeyError, ValueError, TypeError) as e:
            jerr = str(e)
            notes.append(f"journal {jpath.name} unusable: {e}")

    if not path.exists():
        if journal is None:
            raise SessionFormatError(f"{path}: missing, and its journal {jpath} is unusable ({jerr})")
        notes.append(f"{path.name} missing: {journal.frames.shape[0]} frames recovered from the journal")
        return _session_from_journal(path, journal, notes)

    try:
        is_h5 = h5py.is_hdf5(path)
    except OSError:
        is_h5 = False
    if not is_h5:
        if journal is not None:
            notes.append(f"{path.name} is not a readable HDF5 file: {journal.frames.shape[0]} frames recovered from the journal")
            return _session_from_journal(path, journal, notes)
        size = path.stat().st_size
        raise SessionFormatError(
            f"{path}: not an HDF5 file ({size} bytes, no HDF5 signature)"
            + (" — an empty file: the recording never started" if size == 0 else "")
        )

    try:
        f, swmr = _open_h5(path)
    except OSError as e:
        if journal is not None:
            notes.append(f"{path.name} could not be opened ({e}): {journal.frames.shape[0]} frames recovered from the journal")
            return _session_from_journal(path, journal, notes)
        raise SessionFormatError(f"{path}: corrupt HDF5 file, cannot be opened ({e})") from None

    with f:
        a = f.attrs
        fmt = _attr_str(a["format"]) if "format" in a else None
        if fmt != FORMAT_NAME:
            raise SessionFormatError(
                f"{path}: HDF5 file but not a psmat session (root attribute 'format' is "
                f"{fmt!r}, expected {FORMAT_NAME!r})"
            )
        version = int(a.get("format_version", -1))
        if version < 1 or version > FORMAT_VERSION:
            raise SessionFormatError(
                f"{path}: session format version {version} is not supported (this psmat reads 1..{FORMAT_VERSION})"
            )
        try:
            kind = _attr_str(a["kind"])
            dname = _attr_str(a.get("frame_dataset", _KINDS[kind]["dataset"]))
            complete = bool(int(a.get("complete", 0)))
            missing = [n for n in (dname, *_PER_FRAME) if n not in f]
            if missing:
                raise SessionFormatError(f"{path}: corrupt session, missing dataset(s) {missing}")
            lengths = {n: int(f[n].shape[0]) for n in (dname, *_PER_FRAME)}
            if complete:
                n = int(a.get("n_frames", lengths[dname]))
                if len(set(lengths.values())) != 1 or n != lengths[dname]:
                    raise SessionFormatError(
                        f"{path}: corrupt session, per-frame datasets disagree in length {lengths} (n_frames={n})"
                    )
            else:
                committed = int(f["committed"][0]) if "committed" in f else min(lengths.values())
                n = min(committed, *lengths.values())
                notes.append(
                    f"interrupted recording (not closed){' opened in SWMR mode' if swmr else ''}: "
                    f"{n} committed frames in the HDF5 file"
                )
            frames = f[dname][:n]
            t = f["host_time_s"][:n]
            valid = f["valid"][:n]
            seq = f["seq"][:n]
            dt = f["device_time_us"][:n]
            device = _read_group_json(f, "device", path) or {}
            calibration = _read_group_json(f, "calibration", path)
            metadata = _read_group_json(f, "metadata", path) or {}
            products = _read_products(f, path)
            counters = dict.fromkeys(COUNTER_NAMES, 0)
            if "counters" in f:
                names = [_attr_str(x) for x in f["counters"].attrs.get("names", list(COUNTER_NAMES))]
                counters.update({k: int(v) for k, v in zip(names, f["counters"][()])})
            created = _attr_str(a.get("created_utc", ""))
        except SessionFormatError:
            raise
        except (OSError, KeyError, ValueError, TypeError, RuntimeError) as e:
            if journal is not None:
                notes.append(f"{path.name} unreadable ({e}): {journal.frames.shape[0]} frames recovered from the journal")
                return _session_from_journal(path, journal, notes)
            raise SessionFormatError(f"{path}: corrupt session file ({type(e).__name__}: {e})") from None

    recovered = False
    if journal is not None and not complete:
        nj = journal.frames.shape[0]
        if nj > n:
            notes.append(f"{nj - n} further frames recovered from the journal {jpath.name} ({nj} in all)")
            frames, t, valid = journal.frames, journal.host_time_s, journal.valid
            seq, dt = journal.seq, journal.device_time_us
            if journal.counters is not None:
                counters = journal.counters
            n, recovered = nj, True
        if journal.n_bad_tail_bytes:
            notes.append(f"journal tail of {journal.n_bad_tail_bytes} bytes discarded (incomplete last record)")
    elif journal is not None and complete:
        notes.append(f"stale journal {jpath.name} ignored: the HDF5 file is complete")

    return _make_session(
        path, kind=kind, frames=frames, t=t, valid=valid, seq=seq, dt=dt, device=device,
        calibration=calibration, metadata=metadata, products=products, counters=counters,
        version=version, created=created, complete=complete, recovered=recovered, notes=notes,
    )


def repair_session(path: str | os.PathLike[str]) -> Session:
    """Turn an interrupted recording into a complete file (recovering the journal), then reload it.

    The recovered data are written to a temporary file that replaces ``path`` atomically;
    the journal is removed afterwards. A complete file is returned unchanged.
    """
    path = Path(path)
    s = load_session(path)
    if s.complete:
        return s
    tmp = path.with_name(path.name + ".repair.tmp")
    for p in (tmp, journal_path(tmp)):
        if p.exists():
            p.unlink()
    with SessionWriter(tmp, s.frame_shape, s.device, s.calibration, s.metadata, kind=s.kind,
                       background=False) as w:
        if s.n_frames:
            w.append(s.counts, s.host_time_s, s.valid,
                     seq=s.seq, device_time_us=s.device_time_us)
        w.set_counters(**s.counters)
    with h5py.File(tmp, "r+") as f:
        f.attrs["created_utc"] = s.created_utc or f.attrs["created_utc"]
        f.attrs["repaired_utc"] = _utc_now()
        f.attrs["repair_notes"] = "; ".join(s.notes)
        if s.products:
            for name, p in s.products.items():
                _write_product(f, name, p.data, p.params, p.unit)
    _fsync_file(tmp)
    os.replace(tmp, path)
    _fsync_dir(path.parent)
    jp = journal_path(path)
    if jp.exists():
        jp.unlink()
    return load_session(path)


# ====================================================================== products
def _write_product(f: h5py.File, name: str, array: ArrayLike, params: Mapping[str, Any], unit: str) -> None:
    g = f.require_group("products")
    if name in g:
        del g[name]
    arr = np.asarray(array)
    if arr.dtype.kind not in "biuf":
        raise TypeError(f"product {name!r} must be a numeric array, got dtype {arr.dtype}")
    if arr.dtype.kind == "b":
        arr = arr.astype(np.uint8)
    ds = g.create_dataset(name, data=arr, chunks=True if arr.ndim and arr.size else None)
    ds.attrs["unit"] = str(unit)
    pj = _to_json(dict(params))
    ds.attrs["params_json"] = pj
    ds.attrs["created_utc"] = _utc_now()
    for k, v in json.loads(pj).items():
        if k in ("unit", "params_json", "created_utc"):
            continue
        if isinstance(v, bool):
            ds.attrs[k] = np.uint8(v)
        elif isinstance(v, (int, float, str)) and not (isinstance(v, int) and not -(2**63) <= v < 2**63):
            ds.attrs[k] = v


def save_product(
    path: str | os.PathLike[str], name: str, array: ArrayLike, params: Mapping[str, Any], unit: str
) -> None:
    """Store a processed product (e.g. ``"G"``, ``"g"``, ``"pressure"``, ``"cop"``) in a session file.

    ``params`` (JSON-serialisable: numbers, strings, lists, dicts, NumPy values) records
    how it was made (method, model parameters, calibration serial, …). A product of the
    same name is replaced. The session must be complete (closed, or repaired with
    :func:`repair_session`).
    """
    path = Path(path)
    if not name or "/" in name or name in (".", ".."):
        raise ValueError(f"invalid product name {name!r}")
    if not path.is_file():
        raise FileNotFoundError(f"session file not found: {path}")
    if journal_path(path).exists():
        raise SessionFormatError(
            f"{path}: the recording is still being written or was interrupted "
            f"({journal_path(path).name} exists); close the writer or call repair_session() first"
        )
    try:
        f = h5py.File(path, "r+")
    except OSError as e:
        raise SessionFormatError(f"{path}: cannot open for writing ({e})") from None
    with f:
        if _attr_str(f.attrs.get("format", "")) != FORMAT_NAME:
            raise SessionFormatError(f"{path}: HDF5 file but not a psmat session")
        _write_product(f, name, array, params, unit)


# ====================================================================== export / summary
def _cell_names(kind: str, shape: tuple[int, ...]) -> list[str]:
    if kind == "imu":
        return [f"s{k}_{a}_deg" for k in range(shape[0]) for a in _IMU_ANGLES[: shape[1]]]
    if kind == "daq":
        return [f"s{k}_count" for k in range(shape[0])]
    r, c = shape
    return [f"c_{i}_{p}" for i in range(r) for p in range(c)]


def export_csv(session: Session | str | os.PathLike[str], path: str | os.PathLike[str], *,
               missing: str | None = None) -> Path:
    """Write one CSV row per frame: ``time_s, valid, seq``, then the frame values.

    Cell columns are ``c_{i}_{p}`` (row-major) for a mat, ``s{k}_{heading|roll|pitch}_deg``
    for the IMUs, ``s{k}_count`` for the material DAQ. ``valid`` is 1/0; ``seq`` is empty
    when unknown. Values are written exactly (integers; shortest round-trip floats).
    ``missing``: if given (e.g. ``""``), the cells of invalid frames are written as this
    string instead of the stored placeholder values.
    """
    s = session if isinstance(session, Session) else load_session(session)
    out = Path(path)
    flat = s.counts.reshape(s.n_frames, -1)
    is_float = flat.dtype.kind == "f"
    seq = s.seq
    with open(out, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["time_s", "valid", "seq", *_cell_names(s.kind, s.frame_shape)])
        ncol = flat.shape[1]
        for k in range(s.n_frames):
            head = [repr(float(s.host_time_s[k])), int(s.valid[k]),
                    "" if seq is None or seq[k] < 0 else int(seq[k])]
            if missing is not None and not s.valid[k]:
                w.writerow(head + [missing] * ncol)
            elif is_float:
                w.writerow(head + [np.format_float_positional(x, unique=True, trim="-") for x in flat[k]])
            else:
                w.writerow(head + flat[k].tolist())
    return out


def info(session: Session | str | os.PathLike[str]) -> str:
    """A human-readable summary of a session (or of the session file at a path)."""
    s = session if isinstance(session, Session) else load_session(session)
    n = s.n_frames
    lines = [f"psmat session: {s.path if s.path is not None else '(in memory)'}"]
    state = "complete" if s.complete else "INTERRUPTED recording"
    if s.recovered:
        state += ", frames recovered from the journal"
    lines.append(f"  kind          {s.kind}, frame shape {s.frame_shape}, format v{s.format_version} ({state})")
    if s.created_utc:
        lines.append(f"  created       {s.created_utc}")
    rate = s.rate_hz
    lines.append(
        f"  frames        {n}, duration {s.duration_s:.3f} s, rate "
        + (f"{rate:.2f} Hz (from host times)" if math.isfinite(rate) else "n/a")
    )
    n_bad = int(n - np.count_nonzero(s.valid))
    pct = 100.0 * n_bad / n if n else 0.0
    lines.append(f"  invalid       {n_bad} frames ({pct:.2f} %)")
    c = s.counters
    lines.append("  counters      " + ", ".join(f"{k} {c.get(k, 0)}" for k in COUNTER_NAMES))
    if s.seq is not None:
        known = s.seq[s.seq >= 0]
        gaps = int(np.sum(np.clip(np.diff(known) - 1, 0, None))) if known.size > 1 else 0
        lines.append(f"  seq           {int(known[0]) if known.size else '-'}..{int(known[-1]) if known.size else '-'}, "
                     f"{gaps} frames missing by sequence number")
    if s.device_time_us is not None:
        known = s.device_time_us[s.device_time_us >= 0]
        if known.size > 1:
            lines.append(f"  device clock  {(known[-1] - known[0]) / 1e6:.3f} s span")

    def kv(d: Mapping[str, Any]) -> str:
        return ", ".join(f"{k}={v}" for k, v in d.items()) if d else "(none)"

    lines.append(f"  device        {kv(s.device)}")
    if s.calibration is None:
        lines.append("  calibration   (none)")
    else:
        cal = {k: v for k, v in s.calibration.items() if not isinstance(v, (list, dict))}
        lines.append(f"  calibration   {kv(cal)}")
    lines.append(f"  metadata      {kv(s.metadata)}")
    if s.products:
        lines.append("  products")
        for name, p in sorted(s.products.items()):
            lines.append(f"    {name:<12}{p.data.shape} {p.data.dtype} [{p.unit}] params: {kv(p.params)}")
    else:
        lines.append("  products      (none)")
    for note in s.notes:
        lines.append(f"  note          {note}")
    return "\n".join(lines)
