"""The crash record of a session being written: an append-only journal of fixed-size CRC'd records.

Format (little-endian; :mod:`psmat.io.session` explains its role):

* ``b"PSMATJ02"``, ``uint32`` header length ``H``, ``H`` bytes of UTF-8 JSON (kind, frame
  shape and dtype, chunk size, device, calibration, metadata, ``profile`` when the recording
  has one (a journal without the key loads with none), record size, ``session``: a
  random id of the recording; for the journal ``PATH.NAME.journal`` of a stream also
  ``stream`` = NAME, with the session's id), ``uint32`` CRC-32 of those ``H`` bytes;
* then records of ``32 + P + 4`` bytes: ``uint8 type`` (0 frame, 1 counters), ``uint8
  valid``, 6 pad bytes, ``float64 host_time_s``, ``int64 seq``, ``int64 device_time_us``,
  ``P`` payload bytes (the frame, or the counters as int64, zero padded), ``uint32`` CRC-32
  of the record's preceding bytes.

Records are found by their own framing, not by their position: a record starts with a type
byte 0 or 1, a valid byte 0 or 1 and six zero bytes, and ends with the CRC-32 of the rest.
A reader that meets a record failing its CRC looks for the next offset where an intact record
starts, so a flipped byte costs that record, and inserted or deleted bytes cost only the records
they touch (docs/spec.md §6). The damaged span's length in records says how many were lost and
which (write order); a torn last record (a write cut short) leaves a tail shorter than a record.
"""

from __future__ import annotations

import json
import mmap
import zlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...frames import FrameBatch

from ._layout import (COUNTER_NAMES, FORMAT_NAME, FORMAT_VERSION, KINDS, MAX_CHUNK_FRAMES, MAX_UTC_OFFSET_S,
                             STREAMS_FORMAT_VERSION, Header, SessionFormatError, check_stream_name, frame_shape_of,
                             stream_journal_candidates)

MAGIC = b"PSMATJ02"
FRAME, COUNTERS = 0, 1
_BLOCK_RECORDS = 4096  # records checked and returned at a time
_PREFIX = 8  # type, valid and six zero pad bytes: the framing every record starts with


def record_dtype(payload: int) -> np.dtype:
    """The structured dtype of one journal record with ``payload`` payload bytes."""
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


def payload_bytes(h: Header) -> int:
    """Payload size: room for one frame or for the counters, whichever is larger."""
    return max(int(np.prod(h.frame_shape)) * h.spec.dtype.itemsize, 8 * len(COUNTER_NAMES))


def encode_header(h: Header, session: str, stream: str | None = None) -> bytes:
    """The journal's first bytes: magic, length, JSON, CRC-32 of the JSON.

    ``session``: the id of the recording, the same in the journals of all its streams;
    ``stream``: the stream's name (None for the root device).
    """
    p = payload_bytes(h)
    doc = {
        "format": FORMAT_NAME + "-journal",
        "format_version": FORMAT_VERSION,
        "kind": h.kind,
        "frame_shape": list(h.frame_shape),
        "frame_dtype": h.spec.dtype.str,
        "chunk_frames": h.chunk_frames,
        "payload_bytes": p,
        "record_bytes": record_dtype(p).itemsize,
        "counter_names": list(COUNTER_NAMES),
        "device": h.device,
        "calibration": h.calibration,
        "metadata": h.metadata,
        "created_utc": h.created_utc,
        "session": session,
    }
    if h.profile is not None:  # absent in the journals of a psmat before profiles: they load with None
        doc["profile"] = h.profile
    if h.utc_offset_s is not None:  # absent in the journals of a psmat before it stored the offset
        doc["utc_offset_s"] = h.utc_offset_s
    if stream is not None:
        doc["stream"] = stream
    hb = json.dumps(doc, allow_nan=True).encode("utf-8")
    return MAGIC + len(hb).to_bytes(4, "little") + hb + zlib.crc32(hb).to_bytes(4, "little")


def _with_crc(rec: NDArray[Any]) -> bytes:
    raw = rec.view(np.uint8).reshape(rec.shape[0], rec.dtype.itemsize)
    for i in range(rec.shape[0]):
        rec["crc"][i] = zlib.crc32(raw[i, :-4].tobytes())
    return rec.tobytes()


def encode_frames(dtype: np.dtype, b: FrameBatch) -> bytes:
    """One CRC'd record per frame of ``b`` (frames already in the kind's dtype, C order)."""
    n = len(b)
    rec = np.zeros(n, dtype)
    rec["type"] = FRAME
    rec["valid"] = b.valid
    rec["host_time_s"] = b.host_time_s
    rec["seq"] = b.seq
    rec["device_time_us"] = b.device_time_us
    flat = b.frames.reshape(n, -1).view(np.uint8)
    rec["payload"][:, : flat.shape[1]] = flat
    return _with_crc(rec)


def encode_counters(dtype: np.dtype, counters: Mapping[str, int]) -> bytes:
    """One CRC'd record holding the cumulative counters (:data:`COUNTER_NAMES` order)."""
    rec = np.zeros(1, dtype)
    rec["type"] = COUNTERS
    rec["payload"][0, : 8 * len(COUNTER_NAMES)] = np.array([counters[k] for k in COUNTER_NAMES], "<i8").view(np.uint8)
    return _with_crc(rec)


def format_ranges(idx: NDArray[Any] | list[int]) -> str:
    """``[0, 1, 2, 5, 8, 9]`` -> ``"0..2, 5, 8..9"``."""
    a = np.asarray(idx, np.int64)
    if a.size == 0:
        return "none"
    cut = np.flatnonzero(np.diff(a) != 1) + 1
    parts = []
    for run in np.split(a, cut):
        parts.append(f"{run[0]}" if run.size == 1 else f"{run[0]}..{run[-1]}")
    return ", ".join(parts)


@dataclass
class Journal:
    """An opened journal: its header, then its records read block by block with :meth:`blocks`.

    ``stream`` is the stream's name for a stream's journal, None for the root device's;
    ``session`` the recording's id (None in a journal of a psmat before streams).
    After a full pass of :meth:`blocks`: ``skipped_frames`` holds the write-order indices of
    frame records lost to damage (a damaged span of bytes counts as as many records as its
    length holds, rounded, and no more frames than the sequence numbers on either side of it
    leave room for; its first record is a counters record when its type byte says so and its
    three times are zero), ``skipped_counters`` the number of damaged counters records, ``garbage_bytes`` the
    bytes skipped that held no record (inserted bytes), ``tail_bytes`` the incomplete last
    record, ``counters`` the last intact counters record, ``frames_read`` the intact frames.
    """

    path: Path
    header: Header
    format_version: int
    record: np.dtype
    body_offset: int
    body_bytes: int
    stream: str | None = None
    session: str | None = None
    skipped_frames: list[int] = field(default_factory=list)
    skipped_counters: int = 0
    garbage_bytes: int = 0
    tail_bytes: int = 0
    counters: dict[str, int] | None = None
    frames_read: int = 0
    _last_seq: int = field(default=-1, repr=False)

    @classmethod
    def open(cls, path: Path) -> Journal:
        """Read and check the header; :class:`SessionFormatError` if it is not an intact journal header.

        Intact means its CRC-32 matches and every field is what a psmat writer writes
        (:func:`_header_fields`): a header whose CRC matches is still not trusted with a kind
        psmat does not know, a shape that is not positive or not the kind's, a size out of
        bounds (a frame holds at most ``_layout.MAX_FRAME_VALUES`` values, so no record size a
        header claims makes the reader allocate more than the journal holds) or a dtype that is
        not the kind's.
        """
        size = path.stat().st_size
        with open(path, "rb") as fh:
            head = fh.read(12)
            if len(head) < 12 or head[:8] != MAGIC:
                raise SessionFormatError(f"{path}: not a psmat session journal (bad or missing magic)")
            hlen = int.from_bytes(head[8:12], "little")
            if 12 + hlen + 4 > size:  # before reading (allocating) hlen bytes
                raise SessionFormatError(f"{path}: journal header truncated ({size - 12} of {hlen + 4} bytes)")
            hb = fh.read(hlen + 4)
        if len(hb) < hlen + 4:
            raise SessionFormatError(f"{path}: journal header truncated ({len(hb)} of {hlen + 4} bytes)")
        if zlib.crc32(hb[:hlen]) != int.from_bytes(hb[hlen:], "little"):
            raise SessionFormatError(f"{path}: journal header damaged (CRC-32 mismatch)")
        try:
            doc = json.loads(hb[:hlen].decode("utf-8"))
            h, version, rec, stream, session = _header_fields(doc)
        except (UnicodeDecodeError, ValueError, KeyError, TypeError) as e:
            raise SessionFormatError(f"{path}: journal header is not a psmat journal header ({e})") from None
        return cls(path=path, header=h, format_version=version, record=rec, body_offset=12 + hlen + 4,
                   body_bytes=max(size - (12 + hlen + 4), 0), stream=stream, session=session)

    def blocks(self) -> Iterator[FrameBatch]:
        """The intact frame records, in write order, a block at a time (damaged spans skipped)."""
        self.skipped_frames, self.skipped_counters, self.garbage_bytes = [], 0, 0
        self.tail_bytes, self.counters, self.frames_read = 0, None, 0
        if self.body_bytes == 0:
            return
        with open(self.path, "rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
            body = memoryview(mm)[self.body_offset:]
            try:
                yield from self._scan(body)
            finally:
                body.release()

    def _scan(self, body: memoryview) -> Iterator[FrameBatch]:
        size, end = self.record.itemsize, len(body)
        frame_no = 0  # write-order index of the next frame record
        self._last_seq = -1  # sequence number of the last intact frame record (-1: none, or not numbered)
        pos = 0
        while pos + size <= end:
            m = min((end - pos) // size, _BLOCK_RECORDS)
            rec = np.frombuffer(body, dtype=self.record, count=m, offset=pos)
            u8 = rec.view(np.uint8).reshape(m, size)
            framed = (u8[:, 0] <= COUNTERS) & (u8[:, 1] <= 1) & ~u8[:, 2:_PREFIX].any(axis=1)
            crc = rec["crc"]
            n_ok = 0  # the intact records before the first damaged one (checked no further than that)
            while n_ok < m and framed[n_ok] and zlib.crc32(u8[n_ok, :-4]) == int(crc[n_ok]):
                n_ok += 1
            if n_ok:
                frame_no = yield from self._emit(rec[:n_ok], frame_no)
                pos += n_ok * size
            if n_ok == m:
                continue
            # a damaged record at pos: the next intact record, wherever its framing and CRC say it is
            nxt = self._resync(body, pos + 1)
            stop = end if nxt is None else nxt
            if nxt is None and stop - pos < size:
                break  # shorter than a record: the torn tail below
            n_span = int(round((stop - pos) / size))  # records the damaged span's length holds
            # a counters record says so in its type byte and has all three times zero
            n_counters = int(n_span > 0 and body[pos] == COUNTERS and not any(body[pos + _PREFIX:pos + 32]))
            n_frames = n_span - n_counters
            if nxt is not None and self._last_seq >= 0:  # sequence numbers tell inserted bytes from lost frames
                nrec = np.frombuffer(body, dtype=self.record, count=1, offset=nxt)[0]
                if nrec["type"] == FRAME and int(nrec["seq"]) > self._last_seq:
                    n_frames = min(n_frames, int(nrec["seq"]) - self._last_seq - 1)
            if n_frames == 0 and n_counters == 0:
                self.garbage_bytes += stop - pos
            self.skipped_counters += n_counters
            self.skipped_frames.extend(range(frame_no, frame_no + n_frames))
            frame_no += n_frames
            if nxt is None:
                return
            pos = nxt
        self.tail_bytes = end - pos

    def _resync(self, body: memoryview, start: int) -> int | None:
        """The first offset >= ``start`` where an intact record begins, or None.

        Candidates are the offsets whose first eight bytes have a record's framing (type 0/1,
        valid 0/1, six zero bytes), found vectorised a window at a time; only those pay a CRC.
        """
        size, end = self.record.itemsize, len(body)
        a = np.frombuffer(body, np.uint8)
        window = 16 * size
        lo = start
        while lo + size <= end:
            hi = min(lo + window, end - size + 1)  # candidate offsets [lo, hi)
            w = a[lo:hi + _PREFIX - 1]
            n = hi - lo
            cand = (w[:n] <= COUNTERS) & (w[1:n + 1] <= 1)
            for k in range(2, _PREFIX):
                cand &= w[k:n + k] == 0
            for off in lo + np.flatnonzero(cand):
                off = int(off)
                crc = int.from_bytes(body[off + size - 4:off + size], "little")
                if zlib.crc32(body[off:off + size - 4]) == crc:
                    return off
            lo = hi
            window *= 2
        return None

    def _emit(self, rec: NDArray[Any], frame_no: int) -> Iterator[FrameBatch]:
        """Counters and frames of a run of intact records; returns the next write-order index."""
        h = self.header
        nbytes = int(np.prod(h.frame_shape)) * h.spec.dtype.itemsize
        cr = rec[rec["type"] == COUNTERS]
        if cr.shape[0]:
            vals = cr["payload"][-1, : 8 * len(COUNTER_NAMES)].copy().view("<i8")
            self.counters = {k: int(v) for k, v in zip(COUNTER_NAMES, vals)}
        fr = rec[rec["type"] == FRAME]
        self.frames_read += fr.shape[0]
        if fr.shape[0]:
            self._last_seq = int(fr["seq"][-1])
        yield FrameBatch(
            frames=fr["payload"][:, :nbytes].copy().view(h.spec.dtype).reshape((fr.shape[0], *h.frame_shape)),
            host_time_s=fr["host_time_s"].astype(np.float64),
            valid=fr["valid"].astype(bool),
            seq=fr["seq"].astype(np.int64),
            device_time_us=fr["device_time_us"].astype(np.int64),
        )
        return frame_no + fr.shape[0]

    def read_all(self) -> FrameBatch:
        """Every intact frame record as one block."""
        parts = list(self.blocks())
        if not parts:
            h = self.header
            return FrameBatch(np.zeros((0, *h.frame_shape), h.spec.dtype), np.zeros(0), np.zeros(0, bool),
                              np.zeros(0, np.int64), np.zeros(0, np.int64))
        return FrameBatch(*(np.concatenate([getattr(p, k) for p in parts]) for k in
                            ("frames", "host_time_s", "valid", "seq", "device_time_us")))

    def damage_notes(self) -> list[str]:
        """What a pass of :meth:`blocks` skipped, one note per kind of damage."""
        notes = []
        n_bad = len(self.skipped_frames) + self.skipped_counters
        if n_bad:
            what = [f"frame(s) {format_ranges(self.skipped_frames)} (write order) lost"] if self.skipped_frames else []
            if self.skipped_counters:
                what.append(f"{self.skipped_counters} counters record(s)")
            notes.append(f"{n_bad} journal record{'s' if n_bad != 1 else ''} damaged and skipped "
                         f"(failed the CRC or moved by inserted/deleted bytes): {'; '.join(what)}")
        if self.garbage_bytes:
            notes.append(f"{self.garbage_bytes} byte(s) between journal records held no record and were skipped "
                         "(no frame lost there)")
        if self.tail_bytes:
            notes.append(f"journal tail of {self.tail_bytes} bytes discarded (incomplete last record)")
        return notes


def _int(doc: Mapping[str, Any], key: str, lo: int, hi: int) -> int:
    v = doc[key]
    if not isinstance(v, int) or isinstance(v, bool) or not lo <= v <= hi:
        raise ValueError(f"{key} {v!r} is not an integer in [{lo}, {hi}]")
    return v


def _dict(doc: Mapping[str, Any], key: str, none_ok: bool = False) -> dict[str, Any] | None:
    v = doc[key]
    if v is None and none_ok:
        return None
    if not isinstance(v, dict):
        raise ValueError(f"{key} is a {type(v).__name__}, not a JSON object")
    return v


def _header_fields(doc: Any) -> tuple[Header, int, np.dtype, str | None, str | None]:
    """A journal header's fields, each checked against what psmat writes; ValueError naming the first that is not."""
    if not isinstance(doc, dict):
        raise ValueError("not a JSON object")
    if doc.get("format", FORMAT_NAME + "-journal") != FORMAT_NAME + "-journal":
        raise ValueError(f"format {doc['format']!r}")
    version = _int(doc, "format_version", 1, STREAMS_FORMAT_VERSION)
    kind = doc["kind"]
    if not isinstance(kind, str) or kind not in KINDS:
        raise ValueError(f"kind {kind!r} is not one of {sorted(KINDS)}")
    shape = doc["frame_shape"]
    if not isinstance(shape, list) or not all(isinstance(x, int) and not isinstance(x, bool) for x in shape):
        raise ValueError(f"frame_shape {shape!r} is not a list of integers")
    fshape = frame_shape_of(kind, tuple(shape))  # positive, the kind's rank, at most MAX_FRAME_VALUES values
    if not isinstance(doc["frame_dtype"], str) or np.dtype(doc["frame_dtype"]) != KINDS[kind].dtype:
        raise ValueError(f"kind {kind!r} with frame dtype {doc['frame_dtype']!r}")
    created = doc["created_utc"]
    if not isinstance(created, str):
        raise ValueError(f"created_utc {created!r} is not a string")
    h = Header(kind=kind, frame_shape=fshape, device=_dict(doc, "device") or {},
               calibration=_dict(doc, "calibration", none_ok=True), metadata=_dict(doc, "metadata") or {},
               created_utc=created, chunk_frames=_int(doc, "chunk_frames", 1, MAX_CHUNK_FRAMES),
               profile=_dict(doc, "profile", none_ok=True) if "profile" in doc else None,
               utc_offset_s=_int(doc, "utc_offset_s", -MAX_UTC_OFFSET_S, MAX_UTC_OFFSET_S) if "utc_offset_s" in doc
               else None)
    p = payload_bytes(h)
    rec = record_dtype(p)
    if "payload_bytes" in doc and _int(doc, "payload_bytes", 0, 2**62) != p:
        raise ValueError(f"payload size {doc['payload_bytes']}, the frame shape needs {p}")
    if _int(doc, "record_bytes", 0, 2**62) != rec.itemsize:
        raise ValueError(f"record size {doc['record_bytes']}, the frame shape needs {rec.itemsize}")
    if doc.get("counter_names", list(COUNTER_NAMES)) != list(COUNTER_NAMES):
        raise ValueError(f"counter_names {doc['counter_names']!r}, expected {list(COUNTER_NAMES)}")
    stream, session = doc.get("stream"), doc.get("session")
    if stream is not None:
        check_stream_name(stream)
    if session is not None and (not isinstance(session, str) or not 0 < len(session) <= 64):
        raise ValueError(f"session id {session!r}")
    return h, version, rec, stream, session


def stream_journals(path: Path, session: str | None) -> tuple[dict[str, Journal], list[str]]:
    """The journals ``PATH.NAME.journal`` of the streams of the recording whose id is ``session``.

    A journal whose header names another stream or session (e.g. the journal of a session
    ``PATH.NAME``, or one left by an earlier recording) is not this session's and is passed
    over; one whose header is unreadable is left out with a note (its stream is lost).
    """
    out: dict[str, Journal] = {}
    notes: list[str] = []
    if session is None:  # a journal written before streams existed
        return out, notes
    for name, q in stream_journal_candidates(path).items():
        try:
            j = Journal.open(q)
        except (SessionFormatError, OSError) as e:
            notes.append(f"stream journal {q.name} unusable, left out ({e})")
            continue
        if j.stream == name and j.session == session:
            out[name] = j
    return out, notes
