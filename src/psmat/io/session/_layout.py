"""The session file's layout: names, kinds, the in-memory classes and the HDF5 file writer.

The layout itself (datasets, attributes, checksums) is documented in :mod:`psmat.io.session`;
this module is the one place that creates it.
"""

from __future__ import annotations

import datetime as _dt
import glob
import json
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import h5py
import numpy as np
from numpy.typing import NDArray

from ...frames import FrameBatch

from ._crc import CRC_NAME

FORMAT_NAME = "psmat-session"
FORMAT_VERSION = 2
#: the version of a file with more than one device (group ``/streams``): an older psmat,
#: which reads up to 2, refuses it rather than silently loading the first device only
STREAMS_FORMAT_VERSION = 3
COUNTER_NAMES: tuple[str, ...] = ("dropped_frames", "bad_frames", "resyncs", "bytes_discarded")
PER_FRAME: tuple[str, ...] = ("host_time_s", "valid", "seq", "device_time_us")
#: the most values one frame may hold (a 1024 x 1024 mat; the wire protocols stop far below it)
MAX_FRAME_VALUES = 1 << 20
#: the most frames per HDF5 chunk (the unit one checksum covers; 256 by default)
MAX_CHUNK_FRAMES = 1 << 16


@dataclass(frozen=True)
class KindSpec:
    """What one kind of device stores: the frame dataset's name, dtype, unit and axes."""

    dataset: str
    dtype: np.dtype
    unit: str
    axes: str


KINDS: dict[str, KindSpec] = {
    "psm": KindSpec("counts", np.dtype("<u2"), "count", "time, row, column"),
    "imu": KindSpec("angles", np.dtype("<f4"), "deg", "time, sensor, (heading, roll, pitch)"),
    "daq": KindSpec("counts", np.dtype("<u2"), "count", "time, sensor"),
    # another program's Lab Streaming Layer stream (a force platform, EEG): any numbers, each
    # channel in the unit its device dict names (``channel_units``)
    "lsl": KindSpec("samples", np.dtype("<f8"), "as device channel_units", "time, channel"),
    # another mat's pressure frames imported from its own software's export (psmat.io.import_pressure):
    # kPa as that software computed them, no raw counts behind them
    "pressure": KindSpec("pressure", np.dtype("<f4"), "kPa", "time, row, column"),
}
# per-frame datasets: dtype, unit, description, fill value of a frame whose chunk is damaged
PER_FRAME_SPEC: dict[str, tuple[str, str, str, Any]] = {
    "host_time_s": ("<f8", "s", "host clock when the frame was received", np.nan),
    "valid": ("u1", "1", "1 = frame passed its checksum/CRC; 0 = placeholder", 0),
    "seq": ("<i8", "1", "device frame sequence number (unwrapped); -1 = unknown", -1),
    "device_time_us": ("<i8", "us", "device clock (unwrapped); -1 = unknown", -1),
}


class SessionFormatError(ValueError):
    """A file is not a (readable) psmat session; the message names the file and the problem."""


# names a stream may not take: the datasets and groups of a session (a stream's name is
# also part of its journal's and its CSV's file name)
RESERVED_NAMES = frozenset({"counts", "angles", "samples", "pressure", *PER_FRAME, "counters", "products", "device",
                            "calibration", "metadata", "profile", "events", "streams", "journal", "partial", CRC_NAME})


def check_stream_name(name: Any) -> str:
    """``name`` if it is a valid stream name (an ASCII identifier, not reserved), else ValueError."""
    if not isinstance(name, str) or not (name.isascii() and name.isidentifier()) or len(name) > 64:
        raise ValueError(f"a stream name is an ASCII identifier of at most 64 characters (e.g. 'imu'), got {name!r}")
    if name in RESERVED_NAMES:
        raise ValueError(f"stream name {name!r} is reserved (one of {sorted(RESERVED_NAMES)})")
    return name


def journal_path(path: str | os.PathLike[str], stream: str | None = None) -> Path:
    """The journal side file of a session file: ``PATH.journal``, or ``PATH.NAME.journal`` for stream ``NAME``."""
    p = Path(path)
    return p.with_name(p.name + ("" if stream is None else f".{stream}") + ".journal")


def stream_journal_candidates(path: str | os.PathLike[str]) -> dict[str, Path]:
    """Files ``PATH.NAME.journal`` with a valid stream name ``NAME``, by name.

    Candidates only: ``s.h5.x.journal`` may as well be the journal of a session ``s.h5.x``;
    the journal's header says whose stream it is.
    """
    p = Path(path)
    out = {}
    for q in sorted(p.parent.glob(glob.escape(p.name) + ".*.journal")):
        name = q.name[len(p.name) + 1 : -len(".journal")]
        try:
            out[check_stream_name(name)] = q
        except ValueError:
            continue
    return out


def partial_path(path: str | os.PathLike[str]) -> Path:
    """Where a session file is built before it atomically replaces ``PATH``: ``PATH.partial``."""
    p = Path(path)
    return p.with_name(p.name + ".partial")


# ====================================================================== in memory
@dataclass(eq=False)
class Product:
    """A processed product stored with a session: the array, its unit and the parameters that made it."""

    data: NDArray[Any]
    unit: str
    params: dict[str, Any] = field(default_factory=dict)
    created_utc: str = ""


@dataclass(frozen=True)
class Header:
    """What a session holds besides its frames: the device and what was recorded.

    ``chunk_frames`` is the number of frames per HDF5 chunk, hence the frames that one
    damaged chunk costs (docs/spec.md §6). ``profile``: the device profile the recording was
    made with (a plain dict, ``psmat.Profile.to_dict()``), None when none was given.
    """

    kind: str
    frame_shape: tuple[int, ...]
    device: dict[str, Any]
    calibration: dict[str, Any] | None
    metadata: dict[str, Any]
    created_utc: str
    chunk_frames: int = 256
    profile: dict[str, Any] | None = None
    #: the recording computer's offset from UTC when the session began (s east of UTC; None: not stored)
    utc_offset_s: int | None = None

    @property
    def spec(self) -> KindSpec:
        return KINDS[self.kind]


def frame_shape_of(kind: str, shape: int | tuple[int, ...]) -> tuple[int, ...]:
    """``shape`` as a tuple, checked against what a ``kind`` device sends (ValueError otherwise)."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {sorted(KINDS)}, got {kind!r}")
    fshape = (int(shape),) if isinstance(shape, (int, np.integer)) else tuple(int(x) for x in shape)
    if kind in ("psm", "pressure") and len(fshape) != 2:
        raise ValueError(f"a {kind} frame shape is (R, C), got {fshape}")
    if kind == "imu" and (len(fshape) != 2 or fshape[1] != 3):
        raise ValueError(f"an imu frame shape is (n_sensors, 3), got {fshape}")
    if kind == "daq" and len(fshape) != 1:
        raise ValueError(f"a daq frame shape is (n_sensors,), got {fshape}")
    if kind == "lsl" and len(fshape) != 1:
        raise ValueError(f"an lsl frame shape is (n_channels,), got {fshape}")
    if any(x < 1 for x in fshape):
        raise ValueError(f"frame shape must be positive, got {fshape}")
    if int(np.prod(fshape, dtype=np.float64)) > MAX_FRAME_VALUES:
        raise ValueError(f"a frame holds at most {MAX_FRAME_VALUES} values, got shape {fshape}")
    return fshape


class StreamBlocks(NamedTuple):
    """What :func:`write_session_file` writes for one stream: header, frame blocks, counters, frame count.

    ``n_frames``: how many frames ``blocks`` yields (None: ``blocks`` is gathered to count them).
    """

    header: Header
    blocks: Iterable[FrameBatch]
    counters: Mapping[str, int]
    n_frames: int | None = None


@dataclass(eq=False)
class Session:
    """A recorded session as loaded by :func:`psmat.io.load_session`.

    Attributes
    ----------
    counts : ndarray
        The raw frames, time first: ``(T, R, C)`` uint16 ADC counts (``kind="psm"``),
        ``(T, 5, 3)`` float32 Euler angles in degrees (``"imu"``), ``(T, 10)`` uint16
        counts (``"daq"``), ``(T, N)`` float64 samples (``"lsl"``), ``(T, R, C)`` float32
        pressure in kPa imported from another mat's software (``"pressure"``: the name
        ``counts`` is kept for every kind, though these are not counts). Also available as
        :attr:`frames`, the name to use for a kind that is not counts.
    host_time_s, valid : ndarray
        ``(T,)`` float64 host receive times (s; NaN where a damaged chunk lost them) and
        bool validity (False for a frame the device flagged or the file lost to damage).
    seq, device_time_us : ndarray or None
        ``(T,)`` int64 device sequence numbers / device clock (µs), -1 where unknown;
        None when the device never sent them (protocol v1).
    device, calibration, metadata : dict
        Device description, calibration used (None if none), subject/trial metadata.
    profile : dict or None
        The device profile the recording was made with (``psmat.Profile.to_dict()``: shape,
        pitch, geometry, circuit, ...); None for a file written without one (older files).
    events : list of (float, str)
        Markers of the recording: (host time in s, on the clock of ``host_time_s``; label),
        sorted by time; ``[]`` when none. Only the root session has them.
    utc_offset_s : int or None
        The recording computer's offset from UTC when the session began (s east of UTC: 3600 in
        Madrid in winter), which turns its wall-clock times into host times (an experimenter's log
        written with the clock on the wall); None in files written before psmat stored it.
    products : dict[str, Product]
    counters : dict[str, int]
        Reader error counters (:data:`COUNTER_NAMES`); empty when they were lost to damage.
    kind : str
    complete : bool
        False for an interrupted recording (writer killed before it closed).
    recovered : bool
        True when the frames were recovered from the journal side file.
    notes : list[str]
        What the loader found or had to do (recovery, damaged records or chunks), for the record.
        The root session's notes also hold each stream's, prefixed ``stream NAME:``.
    streams : dict[str, Session]
        The other devices recorded with this one, on the same host clock, by stream name
        (e.g. ``"imu"``); empty for a one-device session. Each is a Session of its own kind
        (no products, no streams; the metadata is the root's).
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
    streams: dict[str, Session] = field(default_factory=dict)
    profile: dict[str, Any] | None = None
    events: list[tuple[float, str]] = field(default_factory=list)
    utc_offset_s: int | None = None

    @property
    def frames(self) -> NDArray[Any]:
        return self.counts

    @property
    def n_frames(self) -> int:
        return int(self.counts.shape[0])

    @property
    def frame_shape(self) -> tuple[int, ...]:
        return tuple(int(x) for x in self.counts.shape[1:])

    def _timed(self) -> NDArray[np.intp]:
        return np.flatnonzero(np.isfinite(self.host_time_s))

    @property
    def duration_s(self) -> float:
        """Host time (s) from the first to the last frame whose time is known; 0 if fewer than two."""
        k = self._timed()
        return float(self.host_time_s[k[-1]] - self.host_time_s[k[0]]) if k.size >= 2 else 0.0

    @property
    def rate_hz(self) -> float:
        """Frame rate (Hz) estimated from the host times; NaN if undefined.

        Frame intervals from the first to the last frame whose time is known, over :attr:`duration_s`.
        """
        k = self._timed()
        d = self.duration_s
        return float(k[-1] - k[0]) / d if k.size >= 2 and d > 0 else float("nan")

    def __repr__(self) -> str:
        return (
            f"Session(kind={self.kind!r}, frames={self.n_frames}, shape={self.frame_shape}, "
            f"duration_s={self.duration_s:.3f}, products={sorted(self.products)}, streams={sorted(self.streams)}, "
            f"path={str(self.path)!r})"
        )


# ====================================================================== JSON and attributes
def utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="milliseconds")


#: the largest offset from UTC a computer's clock may keep (s): UTC-12 ... UTC+14 with room
MAX_UTC_OFFSET_S = 18 * 3600


def utc_offset_value(v: Any) -> int | None:
    """A stored ``utc_offset_s`` (s east of UTC) as an int, or None when it is none an offset a clock keeps."""
    try:
        off = int(np.asarray(v).item())
    except (TypeError, ValueError):
        return None
    return off if abs(off) <= MAX_UTC_OFFSET_S else None


def local_utc_offset_s() -> int:
    """This computer's offset from UTC now (s east of UTC), as its time zone says (daylight saving included)."""
    off = _dt.datetime.now().astimezone().utcoffset()
    return int(off.total_seconds()) if off is not None else 0


def psmat_version() -> str:
    """The running psmat's version (``psmat.__version__``, written only in ``psmat/_version.py``)."""
    from ..._version import __version__

    return __version__


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


def to_json(d: Any) -> str:
    return json.dumps(d, default=_json_default, allow_nan=True, sort_keys=False)


def as_dict(d: Any, what: str) -> dict[str, Any] | None:
    """A mapping (or an object with ``to_dict()``) as plain JSON types; None stays None."""
    if d is None:
        return None
    if hasattr(d, "to_dict") and not isinstance(d, Mapping):
        d = d.to_dict()
    if not isinstance(d, Mapping):
        raise TypeError(f"{what} must be a dict (or have .to_dict()), got {type(d).__name__}")
    out: dict[str, Any] = json.loads(to_json(dict(d)))  # normalise: plain JSON types, checks serialisability
    return out


def set_flat_attrs(obj: h5py.HLObject, d: Mapping[str, Any], skip: tuple[str, ...] = ("json",)) -> None:
    """One attribute per scalar, string or flat numeric/string list entry of ``d`` (so ``h5dump -A`` shows them)."""
    for k, v in d.items():
        if k in skip or not isinstance(k, str) or not k:
            continue
        if isinstance(v, bool):
            put_attr(obj, k, np.uint8(v))
        elif isinstance(v, (int, float)):
            if isinstance(v, int) and not (-(2**63) <= v < 2**63):
                continue
            put_attr(obj, k, v)
        elif isinstance(v, str):
            put_attr(obj, k, v)
        elif isinstance(v, (list, tuple)) and v:
            if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
                arr = np.asarray(v)
                if arr.dtype.kind in "if":
                    put_attr(obj, k, arr)
            elif all(isinstance(x, str) for x in v):
                put_attr(obj, k, list(v))


def put_attr(obj: h5py.HLObject, name: str, value: Any) -> None:
    """Set an attribute; strings (and lists of strings) as fixed-length UTF-8.

    Fixed-length strings live in the object's header, which carries a checksum; HDF5's
    variable-length strings would live in the global heap, which has none (and whose
    damaged lengths can hang the library), so no string of a session file is one.
    """
    if isinstance(value, str) or (isinstance(value, list) and value and all(isinstance(x, str) for x in value)):
        raw = np.array([x.encode("utf-8") for x in value] if isinstance(value, list) else value.encode("utf-8"))
        width = max(raw.dtype.itemsize, 1)
        obj.attrs.create(name, raw.astype(f"S{width}"), dtype=h5py.string_dtype("utf-8", width))
    else:
        obj.attrs[name] = value


def attr_str(v: Any) -> str:
    if isinstance(v, bytes):
        return v.decode("utf-8")
    if isinstance(v, np.ndarray) and v.shape == ():
        return attr_str(v.item())
    return str(v)
