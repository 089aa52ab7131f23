"""Loading a session (a finished HDF5 file, or the journal a killed writer left) and repairing one.

Every error is one :class:`SessionFormatError` naming the file (docs/spec.md §6). A damaged HDF5
chunk costs its frames only: they load as invalid, with a note naming the dataset and the
frames; a damaged journal record costs that record only.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from ..._atomic import fsync_dir
from ...frames import FrameBatch

from ._journal import Journal, format_ranges, stream_journals
from ._build import write_session_file
from ._layout import (
    COUNTER_NAMES,
    utc_offset_value,
    FORMAT_NAME,
    KINDS,
    PER_FRAME,
    PER_FRAME_SPEC,
    STREAMS_FORMAT_VERSION,
    Header,
    Session,
    SessionFormatError,
    StreamBlocks,
    attr_str,
    check_stream_name,
    journal_path,
    utc_now,
)
from ._crc import CRC_NAME, chunk_crc
from ._events import read_events, read_journal
from ._products import read_products
from ._storage import check_device, check_objects
from ._truncated import (
    TRUNCATED,
    PaddedFile,
    array_lost,
    check_recorded_size,
    chunk_lost,
    lost_note,
    truncation,
)

# what h5py and NumPy raise on bytes that do not decode (damaged metadata, wrong types)
_DECODE_ERRORS = (OSError, KeyError, ValueError, TypeError, RuntimeError, IndexError, AttributeError, OverflowError)


def load_session(path: str | os.PathLike[str], *, use_journal: bool = True, frames: bool = True) -> Session:
    """Load a session file, or recover an interrupted recording from its journal.

    Parameters
    ----------
    path : str or Path
        The session file (``.h5``). Its journal ``PATH.journal`` (and its streams' journals
        ``PATH.NAME.journal``, its events journal ``PATH.events.journal``) is read when the
        file is missing (the writer was killed before it closed) or unreadable.
    use_journal : bool
        False: read the HDF5 file only.
    frames : bool
        False: every check of the file's structure and metadata, but no frame read: the
        session comes back with none (``n_frames`` 0), its notes without the damaged chunks
        (those are found only by reading them). For listing a folder of sessions at a
        third of the cost; a recording recovered from its journal is read whole.

    Returns
    -------
    Session
        ``notes`` says what the loader found: frames recovered from the journal, journal
        records skipped (which frames), damaged chunks (which dataset, which frames; those
        frames are loaded with ``valid=False``). ``streams`` holds the other devices
        recorded with it, each checked the same way (its notes also in the root's, prefixed
        ``stream NAME:``).

    Raises
    ------
    FileNotFoundError
        Neither the file nor its journal exists.
    SessionFormatError
        Anything else that keeps the file from loading: not an HDF5 file, not a psmat
        session, a newer format version, damaged metadata, a file cut short inside its
        metadata; the message names the file. A file cut short among its frames loads with
        the frames of the chunks before the cut (:mod:`._truncated`); with its journal
        beside it, from the journal.
    """
    path = Path(path)
    jpath = journal_path(path)
    have_j = use_journal and jpath.is_file()
    if not path.exists() and not have_j:
        raise FileNotFoundError(f"session file not found: {path}")
    if path.exists() and not path.is_file():
        raise SessionFormatError(f"{path}: not a regular file")
    if not path.exists():
        return _from_journal(path, jpath, f"{path.name} missing (the writer did not close)")
    notes: list[str] = []
    try:
        s = _from_h5(path, notes, frames)
    except SessionFormatError as e:
        if not have_j:
            raise
        return _from_journal(path, jpath, f"{path.name} unusable ({e})")
    if have_j and not s.complete:
        return _from_journal(path, jpath, f"{path.name} was not closed")
    cut = [x for x in s.notes if x.startswith(TRUNCATED)] if have_j else []
    if cut:  # a file cut short lost frames its journal still holds
        try:
            return _from_journal(path, jpath, f"{path.name} unusable as it is ({cut[0]})")
        except SessionFormatError as e:
            s.notes.append(str(e))
            return s
    if have_j:
        s.notes.append(f"stale journal {jpath.name} ignored: the HDF5 file is complete")
    return s


def replacement_journal(path: str | os.PathLike[str], session: Session | None = None) -> Journal | None:
    """The journal beside the finished file ``path`` when it is another recording's (started at
    another time: one that was to replace the file and did not close), else None (no journal, an
    unreadable one, or the leftover of the file's own recording)."""
    path = Path(path)
    jpath = journal_path(path)
    if not jpath.is_file():
        return None
    try:
        j = Journal.open(jpath)
        if session is None:
            session = load_session(path)
    except (SessionFormatError, OSError):
        return None
    if not session.complete or j.header.created_utc == session.created_utc:
        return None
    return j


def repair_session(path: str | os.PathLike[str], *, replace_finished: bool = False) -> Session:
    """Turn an interrupted recording into a complete file (from its journals), then reload it.

    The recovered frames (of every stream) are written to ``PATH.partial``, which replaces
    ``path`` atomically; the journals are removed afterwards. A complete file is returned
    unchanged, unless ``replace_finished`` and its journal is another recording's (started at
    another time: one that was to replace the file, e.g. ``psmat record --overwrite``, and did
    not close, :func:`replacement_journal`): that recording then
    replaces the file.
    """
    path = Path(path)
    s = load_session(path)
    if s.complete:
        j = replacement_journal(path, s) if replace_finished else None
        if j is None:
            return s
        s = _from_journal(path, j.path, f"{path.name} held an earlier recording (created {s.created_utc}), "
                                        "replaced by this one")
    streams = {name: StreamBlocks(_header(st, s.created_utc), [_block(st)], st.counters)
               for name, st in s.streams.items()}
    write_session_file(path, _header(s, s.created_utc), [_block(s)], s.counters, products=s.products,
                       attrs={"repaired_utc": utc_now(), "repair_notes": "; ".join(s.notes)}, streams=streams,
                       events=s.events)
    for p in (journal_path(path, "events"), *(journal_path(path, name) for name in s.streams), journal_path(path)):
        p.unlink(missing_ok=True)
    fsync_dir(path.parent)
    return load_session(path)


def _header(s: Session, created: str) -> Header:
    return Header(kind=s.kind, frame_shape=s.frame_shape, device=s.device, calibration=s.calibration,
                  metadata=s.metadata, created_utc=created or utc_now(), profile=s.profile,
                  utc_offset_s=s.utc_offset_s)


def _block(s: Session) -> FrameBatch:
    n = s.n_frames
    return FrameBatch(s.counts, s.host_time_s, s.valid,
                      s.seq if s.seq is not None else np.full(n, -1, np.int64),
                      s.device_time_us if s.device_time_us is not None else np.full(n, -1, np.int64))


def _add_streams(s: Session, streams: dict[str, Session], notes: list[str]) -> Session:
    """Attach ``streams`` to the root session ``s``; their notes (and ``notes``) join the root's."""
    s.streams = streams
    s.notes.extend(notes)
    for name, st in streams.items():
        s.notes.extend(f"stream {name}: {n}" for n in st.notes)
    return s


# ====================================================================== journal
def _from_journal(path: Path, jpath: Path, why: str) -> Session:
    try:
        j = Journal.open(jpath)
        b = j.read_all()
    except (SessionFormatError, OSError, ValueError) as e:
        raise SessionFormatError(f"{path}: {why}, and its journal is unusable ({e})") from None
    notes = [f"{why}: {len(b)} frames recovered from the journal {jpath.name}", *j.damage_notes()]
    h = j.header
    found, lost = stream_journals(path, j.session)
    streams = {}
    for name, sj in sorted(found.items()):
        try:
            sb = sj.read_all()
        except (OSError, ValueError) as e:
            lost.append(f"stream journal {sj.path.name} unusable, left out ({e})")
            continue
        streams[name] = _session(path, sj.header.kind, sb, device=sj.header.device, calibration=None,
                                 metadata=dict(h.metadata), counters=sj.counters or dict.fromkeys(COUNTER_NAMES, 0),
                                 version=STREAMS_FORMAT_VERSION, created=h.created_utc, complete=False, recovered=True,
                                 notes=[f"{len(sb)} frames recovered from the journal {sj.path.name}",
                                        *sj.damage_notes()])
    events: list[tuple[float, str]] = []
    ejpath = journal_path(path, "events")
    if j.session is not None and ejpath.is_file():  # the markers, in a journal of their own (._events)
        events, ev_notes = read_journal(ejpath, j.session)
        notes.extend(ev_notes)
        if events:
            notes.append(f"{len(events)} event(s) recovered from the journal {ejpath.name}")
    s = _session(path, h.kind, b, device=h.device, calibration=h.calibration, metadata=h.metadata,
                 profile=h.profile, events=sorted(events, key=lambda e: e[0]),
                 counters=j.counters or dict.fromkeys(COUNTER_NAMES, 0),
                 version=STREAMS_FORMAT_VERSION if streams else j.format_version,
                 created=h.created_utc, complete=False, recovered=True, notes=notes, utc_offset_s=h.utc_offset_s)
    return _add_streams(s, streams, lost)


def _utc_offset(attrs: Any, notes: list[str]) -> int | None:
    """The file's ``utc_offset_s`` (s east of UTC), None when it has none (older files) or a value that is
    no offset a clock keeps (noted)."""
    v = attrs.get("utc_offset_s")
    if v is None:
        return None
    off = utc_offset_value(v)
    if off is None:
        notes.append(f"utc_offset_s {v!r} is not an offset from UTC in s: left out")
    return off


def _session(path: Path, kind: str, b: FrameBatch, **kw: Any) -> Session:
    seq, dt = b.seq, b.device_time_us
    return Session(path=path, kind=kind, counts=b.frames, host_time_s=b.host_time_s, valid=b.valid,
                   seq=seq if np.any(seq >= 0) else None, device_time_us=dt if np.any(dt >= 0) else None,
                   products=kw.pop("products", {}), format_version=kw.pop("version"),
                   created_utc=kw.pop("created"), **kw)


# ====================================================================== HDF5
def _from_h5(path: Path, notes: list[str], frames: bool = True) -> Session:
    try:
        cut = truncation(path)  # shorter than its superblock records: HDF5 alone refuses it
    except OSError:
        cut = None
    if cut is not None:
        return _from_cut_h5(path, notes, cut, frames)
    try:
        is_h5 = h5py.is_hdf5(path)
    except OSError:
        is_h5 = False
    if not is_h5:
        size = path.stat().st_size
        raise SessionFormatError(
            f"{path}: not an HDF5 file ({size} bytes, no HDF5 signature)"
            + (" — an empty file: the recording never started" if size == 0 else "")
        )
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise SessionFormatError(f"{path}: corrupt HDF5 file, cannot be opened ({e})") from None
    try:
        with f:
            return _read_open(f, path, notes, frames=frames)
    except SessionFormatError:
        raise
    except _DECODE_ERRORS as e:
        raise SessionFormatError(f"{path}: corrupt session file ({type(e).__name__}: {e})".replace("\n", " ")) from None


def _from_cut_h5(path: Path, notes: list[str], cut: tuple[int, int], frames: bool = True) -> Session:
    """A file cut short (:mod:`._truncated`): read with zeros past the cut; the chunks there are lost."""
    why = f"{path}: truncated at byte {cut[0]} of {cut[1]} (the size its superblock records)"
    padded = PaddedFile(path, cut[1])
    try:
        try:
            f = h5py.File(padded, "r")
        except OSError as e:
            raise SessionFormatError(f"{why}; the cut is in its metadata, it cannot be opened ({e})") from None
        with f:
            return _read_open(f, path, notes, cut, frames)
    except SessionFormatError:
        raise
    except _DECODE_ERRORS as e:
        raise SessionFormatError(f"{why}; the cut is in its metadata ({type(e).__name__}: {e})"
                                 .replace("\n", " ")) from None
    finally:
        padded.close()


def _read_open(f: h5py.File, path: Path, notes: list[str], cut: tuple[int, int] | None = None,
               frames: bool = True) -> Session:
    """The session in the open file ``f``; ``cut``: ``(bytes held, bytes recorded)`` of a file cut short;
    ``frames`` False: no frame read (:func:`load_session`)."""
    a = f.attrs
    fmt = attr_str(a["format"]) if "format" in a else None
    if fmt != FORMAT_NAME:
        raise SessionFormatError(
            f"{path}: HDF5 file but not a psmat session (root attribute 'format' is {fmt!r}, expected {FORMAT_NAME!r})"
        )
    version = int(a.get("format_version", -1))
    if version < 1 or version > STREAMS_FORMAT_VERSION:
        raise SessionFormatError(
            f"{path}: session format version {version} is not supported (this psmat reads 1..{STREAMS_FORMAT_VERSION})"
        )
    complete = bool(int(a.get("complete", 0)))
    # before any data is read: nothing but plain datasets stored here (a cut file: in the size it records)
    check_objects(f, path, stored=complete, size=None if cut is None else cut[1])
    if cut is not None:
        check_recorded_size(f, path, cut)
    kind, block = _read_device(f, path, complete, notes, cut, frames)
    metadata = _group_json(f, "metadata", path) or {}
    created = attr_str(a.get("created_utc", ""))
    s = _session(
        path, kind, block,
        device=_group_json(f, "device", path) or {},
        calibration=_group_json(f, "calibration", path),
        metadata=metadata,
        profile=_group_json(f, "profile", path),
        events=read_events(f, notes, None if cut is None else cut[0]),
        products=read_products(f, notes),
        counters=_counters(f, notes),
        version=version, created=created,
        complete=complete, recovered=False, notes=notes, utc_offset_s=_utc_offset(a, notes),
    )
    streams: dict[str, Session] = {}
    lost: list[str] = []
    for name in f["streams"] if "streams" in f else ():
        st_notes: list[str] = []
        try:
            g = f["streams"][check_stream_name(name)]
            kind_k, block_k = _read_device(g, path, complete, st_notes, cut, frames)
            streams[name] = _session(path, kind_k, block_k, device=_group_json(g, "device", path) or {},
                                     calibration=None, metadata=dict(metadata), counters=_counters(g, st_notes),
                                     version=version, created=created, complete=complete, recovered=False,
                                     notes=st_notes)
        except (SessionFormatError, *_DECODE_ERRORS) as e:  # a damaged stream costs that stream only
            lost.append(f"stream {name!r} damaged and left out ({e})".replace("\n", " "))
    return _add_streams(s, streams, lost)


def _read_device(g: h5py.Group, path: Path, complete: bool, notes: list[str],
                 cut: tuple[int, int] | None = None, frames: bool = True) -> tuple[str, FrameBatch]:
    """One device's frames from ``g`` (``/`` or ``/streams/NAME``): its kind and frames, damaged chunks invalid.

    Kind, dtypes, shapes and lengths are checked (:func:`check_device`) before anything is
    read; each chunk is then read alone and checked against its Fletcher-32 and, in files that
    have them, its CRC-32 (:mod:`._crc`). In a file cut short (``cut``: bytes held,
    bytes recorded) a chunk not wholly stored before the cut is lost, not read: its frames are
    invalid, noted with the cut (:mod:`._truncated`). ``frames`` False: the same checks and notes
    but no chunk read, and no frames returned (a damaged chunk is then not seen).
    """
    a = g.attrs
    kind = attr_str(a["kind"])
    if kind not in KINDS or attr_str(a.get("frame_dataset", KINDS[kind].dataset)) != KINDS[kind].dataset:
        raise SessionFormatError(f"{path}: corrupt session, unknown kind {kind!r} or frame dataset in {g.name}")
    dname = KINDS[kind].dataset
    n = check_device(g, path, kind, complete)[1]
    if not complete:  # a format-1 SWMR file whose writer was killed, its flag cleared (h5clear -s)
        notes.append(f"interrupted recording (not closed): {n} committed frames in the HDF5 file")
    names = (dname, *PER_FRAME)
    tables = _crc_tables(g, names, n, path, cut)
    fill = 0 if KINDS[kind].dtype.kind in "ui" else np.nan
    held = None if cut is None else cut[0]
    lost = np.zeros(n, bool)
    counts, bad = _read_chunked(g[dname], n, fill, notes, tables.get(dname), held, lost, frames)
    cols = {}
    for name in PER_FRAME:
        cols[name], bad_k = _read_chunked(g[name], n, PER_FRAME_SPEC[name][3], notes, tables.get(name), held, lost,
                                          frames)
        bad |= bad_k
    if cut is not None:
        notes.append(lost_note(cut, format_ranges(np.flatnonzero(lost))))
    unchecked = [n_ for n_ in names if not g[n_].fletcher32]
    if unchecked:
        notes.append(f"{', '.join(unchecked)} carry no checksums (written by an older psmat): "
                     "damage there cannot be seen")
    elif not tables:
        notes.append("the frames carry Fletcher-32 only (written by an older psmat, no CRC-32 per chunk): "
                     "a 16-bit word changed between 00 00 and FF FF, or a chunk moved to another position, "
                     "cannot be seen")
    valid = cols["valid"].astype(bool) & ~bad  # docs/spec.md §6: a damaged frame is never returned as valid
    return kind, FrameBatch(counts, cols["host_time_s"], valid, cols["seq"], cols["device_time_us"])


def _crc_tables(g: h5py.Group, names: tuple[str, ...], n: int, path: Path,
                cut: tuple[int, int] | None = None) -> dict[str, NDArray[np.uint32]]:
    """The CRC-32 tables of ``g``'s per-frame datasets (none in a file of an older psmat), each checked for shape.

    ``cut``: a file cut short, whose tables must be stored before the cut (a session file
    stores them before its frames).
    """
    if CRC_NAME not in g:
        return {}
    cg = g[CRC_NAME]
    out = {}
    for name in names:
        t = cg.get(name) if isinstance(cg, h5py.Group) else None
        ds = g[name]
        c = int(ds.chunks[0]) if ds.chunks else max(n, 1)
        want = -(-n // c)
        if (not isinstance(t, h5py.Dataset) or t.dtype != np.dtype("<u4") or t.shape != (want,)
                or int(np.asarray(t.attrs.get("chunk_frames", -1)).reshape(-1)[0]) != c):
            raise SessionFormatError(f"{path}: {g.name.rstrip('/')}/{CRC_NAME}/{name} is not the CRC-32 table of "
                                     f"{ds.name} ({want} chunks of {c} frames)")
        if cut is not None and array_lost(t, cut[0]):
            raise SessionFormatError(f"{path}: truncated at byte {cut[0]} of {cut[1]}, which cuts {t.name}, the "
                                     f"CRC-32 table of {ds.name}")
        out[name] = t[()]
    return out


def _read_chunked(ds: h5py.Dataset, n: int, fill: Any, notes: list[str], crcs: NDArray[np.uint32] | None = None,
                  held: int | None = None, lost: NDArray[np.bool_] | None = None, frames: bool = True
                  ) -> tuple[NDArray[Any], NDArray[np.bool_]]:
    """Rows ``[0, n)`` of ``ds``, chunk by chunk: a chunk failing a checksum becomes ``fill``, flagged.

    ``crcs``: the dataset's CRC-32 per chunk (:mod:`._crc`), checked after its Fletcher-32.
    ``held``: the bytes a file cut short holds; a chunk not wholly within them is not read but
    becomes ``fill``, flagged in ``bad`` and in ``lost`` (no damage note: the caller notes the cut).
    ``frames`` False: no chunk read, only ``lost`` marked; no rows and no flags come back.
    """
    out = np.empty((n if frames else 0, *ds.shape[1:]), ds.dtype)
    bad = np.zeros(n, bool)
    gone = np.zeros(n, bool)  # past the cut
    step = ds.chunks[0] if ds.chunks else max(n, 1)
    for i, a in enumerate(range(0, n, step)):
        b = min(a + step, n)
        if held is not None and (array_lost(ds, held) if ds.chunks is None else chunk_lost(ds, a, held)):
            if frames:
                out[a:b] = fill  # past the cut: zeros, never returned as frames
            bad[a:b] = gone[a:b] = True
            continue
        if not frames:
            continue
        try:
            out[a:b] = ds[a:b]
        except OSError:  # Fletcher-32 mismatch (or an unreadable chunk)
            out[a:b] = fill
            bad[a:b] = True
            continue
        if crcs is not None and chunk_crc(ds.name, i, out[a:b]) != int(crcs[i]):
            out[a:b] = fill
            bad[a:b] = True
    if lost is not None:
        lost |= gone
    if not frames:
        return out, np.zeros(0, bool)
    damaged = bad & ~gone
    if damaged.any():
        idx = np.flatnonzero(damaged)
        notes.append(f"{ds.name}: damaged chunk(s) (checksum failed), frames {format_ranges(idx)} "
                     f"loaded as invalid")
    return out, bad


def _group_json(f: h5py.Group, name: str, path: Path) -> dict[str, Any] | None:
    if name not in f:
        return None
    g = f[name]
    if "json" not in g.attrs:
        return {k: _attr_value(v) for k, v in g.attrs.items()}
    try:
        d = json.loads(attr_str(g.attrs["json"]))
    except json.JSONDecodeError as e:
        raise SessionFormatError(f"{path}: {g.name} attribute 'json' is not valid JSON ({e})") from None
    if not isinstance(d, dict):
        raise SessionFormatError(f"{path}: {g.name} attribute 'json' is not a JSON object")
    return d


def _attr_value(v: Any) -> Any:
    if isinstance(v, bytes):
        return v.decode("utf-8")
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    return v


def _counters(g: h5py.Group, notes: list[str]) -> dict[str, int]:
    """The reader's counters; empty, with a note, when their chunk is damaged."""
    counters = dict.fromkeys(COUNTER_NAMES, 0)
    if "counters" not in g:
        return counters
    ds = g["counters"]
    names = [attr_str(x) for x in ds.attrs.get("names", list(COUNTER_NAMES))]
    if not isinstance(ds, h5py.Dataset) or ds.dtype.kind not in "iu" or ds.shape != (len(names),) or len(names) > 64:
        raise SessionFormatError(f"{g.file.filename}: {g.name.rstrip('/')}/counters is not {len(names)} counters "
                                 f"(dtype {getattr(ds, 'dtype', None)}, shape {getattr(ds, 'shape', None)})")
    try:
        values = ds[()]
    except OSError:
        values = None
    crc = ds.attrs.get(CRC_NAME)
    if values is None or (crc is not None and chunk_crc(ds.name, 0, values) != int(np.asarray(crc).reshape(-1)[0])):
        notes.append(f"{ds.name}: damaged (checksum failed), the reader's counters are unknown")
        return {}
    counters.update({k: int(v) for k, v in zip(names, values)})
    return counters
