"""Events (markers) of a session: their own crash journal while recording, ``/events`` in the file.

An event is a host time (s, the clock of ``/host_time_s``) and a label of at most
:data:`MAX_LABEL_BYTES` bytes of UTF-8 (no NUL character). :mod:`psmat.io.session` explains
where they live; this module is the one place that writes and reads them.

The events journal ``PATH.events.journal`` (little-endian):

* ``b"PSMATE01"``, ``uint32`` header length ``H``, ``H`` bytes of UTF-8 JSON (format, version,
  ``session``: the recording's random id, the one of ``PATH.journal``; label limit, record
  size, ``created_utc``), ``uint32`` CRC-32 of those ``H`` bytes;
* then one record of :data:`RECORD_BYTES` (220) bytes per event: ``uint8`` tag ``0xE5``,
  ``uint8`` label length ``n`` (0..200), six zero bytes, ``float64`` host time (s), 200 bytes of
  label (``n`` bytes of UTF-8, zero padded), ``uint32`` CRC-32 of the 216 bytes before it.

Records have one size and a framing of their own (tag, length, six zero bytes), so a reader
that meets a record failing its CRC finds the next intact one as the frame journal's reader
does (:mod:`._journal`): a flipped byte costs that event only.

In the file, ``/events`` holds ``host_time_s`` ``(E,)`` float64 and ``label_utf8`` ``(E, W)``
uint8 (each label's UTF-8 bytes, NUL padded to ``W``, the longest label's length), sorted by
time, chunked ``c = min(64, E)`` events a chunk with Fletcher-32, and their CRC-32 per chunk in
``/events/crc32/NAME`` (:mod:`._crc`; attribute ``chunk_events`` = ``c``): a damaged chunk costs
its ``c`` events only. Fixed-width labels keep every chunk of both datasets on the same events,
which an offsets-and-bytes layout would not.
"""

from __future__ import annotations

import json
import math
import os
import re
import struct
import threading
import zlib
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from ..._atomic import fsync_dir
from ._crc import CRC_NAME, ChunkCrcs, chunk_crc
from ._layout import put_attr
from ._truncated import chunk_lost

#: the longest label, in bytes of UTF-8
MAX_LABEL_BYTES = 200
#: the most events one chunk of ``/events`` holds (the events one damaged chunk costs)
EVENTS_CHUNK = 64
GROUP = "events"
MAGIC = b"PSMATE01"
_TAG = 0xE5
_RECORD = struct.Struct(f"<BB6xd{MAX_LABEL_BYTES}s")
RECORD_BYTES = _RECORD.size + 4
#: where an intact record may begin: its tag, a length up to the limit, six zero bytes
_FRAMING = re.compile(b"\\xe5[\\x00-\\x%02x]\\x00{6}" % MAX_LABEL_BYTES, re.DOTALL)
_O_BINARY = getattr(os, "O_BINARY", 0)

Event = tuple[float, str]


def check_event(host_time_s: Any, label: Any) -> tuple[float, bytes]:
    """The event as (time in s, label's UTF-8 bytes), or one ValueError/TypeError line saying what is wrong."""
    if isinstance(host_time_s, bool) or not isinstance(host_time_s, (int, float, np.integer, np.floating)):
        raise TypeError(f"an event's host_time_s is a number of seconds, got {type(host_time_s).__name__}")
    t = float(host_time_s)
    if not math.isfinite(t):
        raise ValueError(f"an event's host_time_s must be finite, got {t!r}")
    if not isinstance(label, str):
        raise TypeError(f"an event's label is a str, got {type(label).__name__}")
    if "\0" in label:
        raise ValueError("an event's label may not contain a NUL character")
    try:
        raw = label.encode("utf-8")
    except UnicodeEncodeError as e:
        raise ValueError(f"an event's label is not encodable as UTF-8 ({e.reason})") from None
    if len(raw) > MAX_LABEL_BYTES:
        raise ValueError(f"an event's label is at most {MAX_LABEL_BYTES} bytes of UTF-8, got {len(raw)} "
                         f"({label[:24]!r}...)")
    return t, raw


def sort_events(events: Iterable[Event]) -> list[Event]:
    """``events`` sorted by time (stable: events of one time keep their order)."""
    return sorted(((float(t), str(lb)) for t, lb in events), key=lambda e: e[0])


# ====================================================================== the journal
def encode_record(t: float, raw: bytes) -> bytes:
    body = _RECORD.pack(_TAG, len(raw), t, raw)
    return body + zlib.crc32(body).to_bytes(4, "little")


def encode_header(session: str, created_utc: str) -> bytes:
    doc = {"format": "psmat-session-events-journal", "format_version": 1, "session": session,
           "max_label_bytes": MAX_LABEL_BYTES, "record_bytes": RECORD_BYTES, "created_utc": created_utc}
    hb = json.dumps(doc).encode("utf-8")
    return MAGIC + len(hb).to_bytes(4, "little") + hb + zlib.crc32(hb).to_bytes(4, "little")


class EventsJournal:
    """The events of a recording being written, each in ``path`` before :meth:`add` returns.

    The file is created with the first event (a recording without events has none). Each
    event is written and fsync'd before :meth:`add` returns: events are rare (markers), so it
    then survives a power cut as well as the process being killed. Thread-safe.
    """

    def __init__(self, path: Path, session: str, created_utc: str) -> None:
        self.path = path
        self._session = session
        self._created = created_utc
        self._fd: int | None = None
        self._n = 0
        self._closed = False
        self._lock = threading.Lock()

    @property
    def n_events(self) -> int:
        return self._n

    def add(self, t: float, raw: bytes) -> None:
        rec = encode_record(t, raw)
        with self._lock:
            if self._closed:
                raise ValueError(f"{self.path}: writer is closed")
            if self._fd is None:
                fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_APPEND | _O_BINARY, 0o644)
                try:
                    _write_all(fd, encode_header(self._session, self._created))
                except BaseException:
                    os.close(fd)
                    raise
                self._fd = fd
                fsync_dir(self.path.parent)
            _write_all(self._fd, rec)
            os.fsync(self._fd)
            self._n += 1

    def close(self) -> BaseException | None:
        """Close the file; the error that kept it from being synced, if any. Idempotent."""
        with self._lock:
            self._closed = True
            fd, self._fd = self._fd, None
        if fd is None:
            return None
        try:
            os.fsync(fd)
        except OSError as e:
            return e
        finally:
            os.close(fd)
        return None

    def checked(self) -> list[Event]:
        """The events read back from the file, in write order; RuntimeError if it lost any."""
        if self._n == 0:
            return []
        events, notes = read_journal(self.path, self._session)
        if len(events) != self._n or notes:
            raise RuntimeError(f"events journal {self.path.name} damaged on disk while recording "
                               f"({'; '.join(notes) or 'no note'}; {len(events)} of {self._n} events intact)")
        return events


def _write_all(fd: int, data: bytes) -> None:
    mv = memoryview(data)
    while mv:
        mv = mv[os.write(fd, mv):]


def _intact(body: bytes, pos: int) -> Event | None:
    """The event of the record at ``pos`` if its framing and CRC hold, else None."""
    if pos + RECORD_BYTES > len(body):
        return None
    rec = body[pos:pos + RECORD_BYTES]
    if zlib.crc32(rec[:-4]) != int.from_bytes(rec[-4:], "little"):
        return None
    tag, n, t, raw = _RECORD.unpack(rec[:-4])
    if tag != _TAG or n > MAX_LABEL_BYTES or any(raw[n:]) or any(rec[2:8]):
        return None
    try:
        return float(t), raw[:n].decode("utf-8")
    except UnicodeDecodeError:
        return None


def read_journal(path: Path, session: str | None) -> tuple[list[Event], list[str]]:
    """The intact events of the events journal ``path``, in write order, and notes on what was not.

    ``session``: the recording's id (its frame journal's); an events journal of another
    recording gives no events and a note. An unreadable header gives no events and a note.
    """
    try:
        data = path.read_bytes()
    except OSError as e:
        return [], [f"events journal {path.name} unreadable, its events are lost ({e})"]
    why = None
    if len(data) < 12 or data[:8] != MAGIC:
        why = "bad or missing magic"
    else:
        hlen = int.from_bytes(data[8:12], "little")
        hb = data[12:12 + hlen]
        if 12 + hlen + 4 > len(data):
            why = "header truncated"
        elif zlib.crc32(hb) != int.from_bytes(data[12 + hlen:16 + hlen], "little"):
            why = "header damaged (CRC-32 mismatch)"
        else:
            try:
                doc = json.loads(hb.decode("utf-8"))
                ok = (isinstance(doc, dict) and doc.get("record_bytes") == RECORD_BYTES
                      and doc.get("max_label_bytes") == MAX_LABEL_BYTES)
            except (UnicodeDecodeError, ValueError):
                ok = False
            if not ok:
                why = "not a psmat events journal header"
            elif doc.get("session") != session:
                return [], [f"events journal {path.name} belongs to another recording, ignored"]
    if why is not None:
        return [], [f"events journal {path.name} unusable, its events are lost ({why})"]
    body = data[16 + hlen:]
    events: list[Event] = []
    lost = garbage = 0
    pos = 0
    while pos + RECORD_BYTES <= len(body):
        ev = _intact(body, pos)
        if ev is not None:
            events.append(ev)
            pos += RECORD_BYTES
            continue
        nxt = next((m.start() for m in _FRAMING.finditer(body, pos + 1) if _intact(body, m.start()) is not None),
                   None)
        stop = len(body) if nxt is None else nxt
        if nxt is None and stop - pos < RECORD_BYTES:
            break
        n = int(round((stop - pos) / RECORD_BYTES))
        lost += n
        garbage += (stop - pos) if n == 0 else 0
        if nxt is None:
            pos = len(body)
            break
        pos = nxt
    notes = []
    if lost:
        notes.append(f"{lost} event record{'s' if lost != 1 else ''} of {path.name} damaged and skipped "
                     "(failed the CRC)")
    if garbage:
        notes.append(f"{garbage} byte(s) between event records held no record and were skipped")
    if len(body) - pos:
        notes.append(f"events journal tail of {len(body) - pos} bytes discarded (incomplete last record)")
    return events, notes


# ====================================================================== the HDF5 file
def _arrays(events: Sequence[Event]) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
    raws = [lb.encode("utf-8") for _, lb in events]
    width = max([1, *(len(r) for r in raws)])
    labels = np.zeros((len(raws), width), np.uint8)
    for i, r in enumerate(raws):
        labels[i, :len(r)] = np.frombuffer(r, np.uint8)
    return np.array([t for t, _ in events], "<f8"), labels


def create_events(f: h5py.File, events: Sequence[Event]) -> list[tuple[h5py.Dataset, NDArray[Any]]]:
    """``/events`` (nothing when there are none), no data written yet: the datasets and their data.

    ``events`` must be sorted by time (:func:`sort_events`). The CRC-32 tables come with the data.
    """
    if not events:
        return []
    times, labels = _arrays(events)
    n, c = len(events), min(EVENTS_CHUNK, len(events))
    g = f.create_group(GROUP)
    g.attrs["n_events"] = np.int64(n)
    out = []
    cg = g.create_group(CRC_NAME)
    for name, arr, unit, desc in (("host_time_s", times, "s", "host clock of the event (the frames' clock)"),
                                  ("label_utf8", labels, "1", "each label's UTF-8 bytes, NUL padded")):
        ds = g.create_dataset(name, shape=arr.shape, dtype=arr.dtype, chunks=(c, *arr.shape[1:]), fletcher32=True)
        put_attr(ds, "unit", unit)
        put_attr(ds, "description", desc)
        crcs = ChunkCrcs(ds.name, c, arr.dtype)
        crcs.feed(arr)
        table = crcs.table()
        t = cg.create_dataset(name, shape=table.shape, dtype="<u4")
        put_attr(t, "unit", "1")
        t.attrs["chunk_events"] = np.int64(c)
        out += [(ds, arr), (t, table)]
    return out


def expected_tables(events: Sequence[Event]) -> dict[str, NDArray[np.uint32]]:
    """The CRC-32 tables ``/events`` must hold for ``events`` (sorted), by dataset name."""
    if not events:
        return {}
    times, labels = _arrays(events)
    c = min(EVENTS_CHUNK, len(events))
    out = {}
    for name, arr in (("host_time_s", times), ("label_utf8", labels)):
        crcs = ChunkCrcs(f"/{GROUP}/{name}", c, arr.dtype)
        crcs.feed(arr)
        out[name] = crcs.table()
    return out


def verify_events(f: h5py.File, path: Path, tables: dict[str, NDArray[np.uint32]]) -> None:
    """RuntimeError unless ``/events`` of the file just written holds the events of ``tables``."""
    if not tables:
        if GROUP in f:
            raise RuntimeError(f"{path}: /events written for a recording without events")
        return
    g = f[GROUP]
    for name, table in tables.items():
        ds = g[name]
        c = int(ds.chunks[0])
        if not np.array_equal(g[CRC_NAME][name][()], table):
            raise RuntimeError(f"{path}: the CRC-32 table of {ds.name} differs from the recording's events")
        for i, a in enumerate(range(0, ds.shape[0], c)):
            try:
                rows = ds[a:a + c]
            except OSError as e:
                raise RuntimeError(f"{path}: {ds.name} events {a}.. unreadable as written ({e})") from None
            if chunk_crc(ds.name, i, rows) != int(table[i]):
                raise RuntimeError(f"{path}: {ds.name} events {a}.. differ from the recording's")


def _structure(g: Any) -> tuple[int, int]:
    """Events count and chunk size of the ``/events`` group ``g``, each dataset's type and shape checked."""
    if not isinstance(g, h5py.Group):
        raise ValueError("/events is not a group")
    times, labels, cg = g.get("host_time_s"), g.get("label_utf8"), g.get(CRC_NAME)
    if not (isinstance(times, h5py.Dataset) and isinstance(labels, h5py.Dataset) and isinstance(cg, h5py.Group)):
        raise ValueError("host_time_s, label_utf8 or the CRC-32 tables missing")
    n = int(times.shape[0]) if times.ndim == 1 else -1
    if times.dtype != np.dtype("<f8") or n < 1:
        raise ValueError(f"host_time_s has dtype {times.dtype}, shape {times.shape}; expected float64 (E,)")
    if (labels.dtype != np.dtype("u1") or labels.ndim != 2 or labels.shape[0] != n
            or not 1 <= labels.shape[1] <= MAX_LABEL_BYTES):
        raise ValueError(f"label_utf8 has dtype {labels.dtype}, shape {labels.shape}; expected uint8 ({n}, 1..200)")
    if np.ndim(g.attrs.get("n_events", n)) != 0 or int(g.attrs.get("n_events", n)) != n:
        raise ValueError(f"attribute n_events disagrees with the {n} events stored")
    c = times.chunks[0] if times.chunks else 0
    if not c or labels.chunks != (c, labels.shape[1]):
        raise ValueError("host_time_s and label_utf8 are not chunked by the same events")
    for name in ("host_time_s", "label_utf8"):
        t = cg.get(name)
        if (not isinstance(t, h5py.Dataset) or t.dtype != np.dtype("<u4") or t.shape != (-(-n // c),)
                or int(np.asarray(t.attrs.get("chunk_events", -1)).reshape(-1)[0]) != c):
            raise ValueError(f"{CRC_NAME}/{name} is not the CRC-32 table of {-(-n // c)} chunks of {c} events")
    return n, int(c)


def read_events(f: h5py.File, notes: list[str], held: int | None = None) -> list[Event]:
    """The events of ``/events`` (``[]`` without the group), sorted by time; damage costs its chunk's events.

    ``held``: the bytes a file cut short holds (a chunk past them is lost). A group whose
    structure is not what psmat writes is left out with a note, as a damaged product is.
    """
    if GROUP not in f:
        return []
    try:
        g = f[GROUP]
        n, c = _structure(g)
        tables = {name: g[CRC_NAME][name][()] for name in ("host_time_s", "label_utf8")}
    except (OSError, KeyError, ValueError, TypeError, IndexError) as e:
        notes.append(f"events damaged and left out ({e})".replace("\n", " "))
        return []
    out: list[Event] = []
    bad = []
    for i, a in enumerate(range(0, n, c)):
        b = min(a + c, n)
        try:
            if held is not None and any(chunk_lost(g[k], a, held) for k in tables):
                raise OSError("past the cut")
            cols = {k: g[k][a:b] for k in tables}
        except OSError:
            bad.append((a, b))
            continue
        if any(chunk_crc(g[k].name, i, cols[k]) != int(tables[k][i]) for k in tables):
            bad.append((a, b))
            continue
        for t, raw in zip(cols["host_time_s"], cols["label_utf8"]):
            out.append((float(t), bytes(raw).rstrip(b"\0").decode("utf-8", "replace")))
    if bad:
        lost = ", ".join(f"{a}..{b - 1}" if b - a > 1 else f"{a}" for a, b in bad)
        notes.append(f"/events: damaged chunk(s) (checksum failed), events {lost} of {n} left out")
    return sort_events(out)
