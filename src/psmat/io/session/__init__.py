"""Recorded sessions: one HDF5 file per recording, crash-safe while it is written (docs/spec.md §6).

A session holds the raw frames of one device (a pressure mat, the spine IMUs or the
material DAQ), per-frame timing and validity, the description of the device and its profile,
the calibration that was used, subject/trial metadata, the reader's error counters, events
(markers: a host time and a label) and any processed products (G, g, pressure, CoP, …) with
the parameters that made them. Other
devices recorded at the same time on the same host clock (the spine IMUs with the mat)
are **streams** of the session, each with its own frames, timing, validity, device and
counters.

Writing::

    with SessionWriter("s01_t1.h5", (16, 16), device={"serial": "0000A1B2", "r_o": 2200.0,
                       "v_ref": 3.3, "bits": 12, "fw": "0.1.0", "protocol": 2, "rate": 100},
                       metadata={"subject": "S01", "trial": 1}, profile=psmat.load_profile("psm16")) as w:
        for frames, t, valid, seq, t_us in reader:         # e.g. from a reader thread
            w.append(frames, t, valid, seq=seq, device_time_us=t_us)
        w.add_event(time.monotonic(), "eyes closed")      # any thread, the frames' clock
        w.set_counters(dropped_frames=reader.dropped)
    s = load_session("s01_t1.h5")
    s.events                                               # [(host time s, "eyes closed")]
    export(s, "counts", "parquet", "s01_t1.counts.parquet")  # also csv, mat; pressure, cop, events

Two devices, one file (each device's reader thread appends to its own stream)::

    with SessionWriter("p01_d1.h5", (16, 16), device=mat_desc, metadata=meta) as w:
        imu = w.add_stream("imu", kind="imu", shape=(5, 3), device=imu_desc)
        w.append(counts, host_time_s, valid, seq=seq, device_time_us=t_us)     # mat thread
        imu.append(angles_deg, host_time_s, valid, seq=seq, device_time_us=t_us)  # IMU thread
    s = load_session("p01_d1.h5")
    s.streams["imu"].counts     # (T, 5, 3) float32 degrees, s.streams["imu"].host_time_s on s's clock

This package's public names come from its private modules: :mod:`._layout` (names,
classes), :mod:`._journal` (the crash record, :class:`Journal`), :mod:`._build` (the HDF5
file written in one go), :mod:`._writer` (:class:`SessionWriter`, :class:`StreamWriter`),
:mod:`._reader` (:func:`load_session`, :func:`repair_session`, :func:`replacement_journal`),
:mod:`._products` (:func:`save_product`, :func:`save_products`), :mod:`._export`
(:func:`export_csv`, :func:`info`, :func:`stream_csv_path`), :mod:`._counts`
(:func:`row_counts`, the error counters per row of a summary), :mod:`._unfinished` (a
recording that was not closed: :func:`unfinished_line`, :func:`journal_only`, ...),
:mod:`._truncated` (a file cut short, :func:`recorded_size`), :mod:`._sample` (a few frames for
an estimate, :func:`sample_frames`; the host times a file spans, :func:`host_time_span`), :mod:`._events` (events: their
journal and ``/events``), :mod:`._export_formats` (:func:`export`: CSV, Parquet, MATLAB),
:mod:`._crc`, :mod:`._storage` and :mod:`._verify` (the checks). :mod:`psmat.io` re-exports the
names most callers need.

On-disk layout (format ``psmat-session``, version 2; 3 with streams)
=====================================================================

Plain HDF5 (superblock v3, ``libver="latest"``, so every metadata object carries a
checksum): any HDF5 reader (h5py, MATLAB ``h5read``, R ``rhdf5``, HDFView, ``h5dump``)
reads it; no pickles, no compound types, no enums. ``T`` is the number of frames; the time
axis is always the first one, chunked (``chunk_frames`` frames per chunk, the same for
every per-frame dataset) and resizable (``maxshape=None``). Every per-frame dataset and
``/counters`` carry HDF5's Fletcher-32 checksum filter, one checksum per chunk, and a CRC-32
per chunk bound to the dataset's path and the chunk's index (:mod:`._crc`: it sees a
``00 00`` word turned ``FF FF`` and a chunk moved, which Fletcher-32 cannot). Every
dataset has a string attribute ``unit``. String attributes are fixed-length UTF-8 (h5py
reads them as ``bytes``): variable-length strings would live in HDF5's global heap, which
has no checksum.

==================  ==================  =========  =======  ==============================================
dataset             shape               dtype      unit     content
==================  ==================  =========  =======  ==============================================
``/counts``         (T, R, C) psm       uint16     count    raw ADC counts of the mat, row-major cells
                    (T, 10) daq                             material-DAQ 10-bit counts, one column per sensor
``/angles``         (T, 5, 3) imu       float32    deg      Euler angles (heading, roll, pitch) per IMU
``/pressure``       (T, R, C) pressure  float32    kPa      another mat's frames imported from its maker's
                                                            export (:func:`psmat.io.import_pressure`)
``/samples``        (T, N) lsl          float64    (below)  another program's Lab Streaming Layer stream
                                                            (a force platform, EEG): N channels, each in
                                                            the unit the device dict's ``channel_units``
                                                            names (the dataset's ``unit`` attribute says so)
``/host_time_s``    (T,)                float64    s        host clock when the frame was received
``/valid``          (T,)                uint8      1        1 = frame passed its checksum/CRC, 0 = kept
                                                            as a placeholder (values meaningless)
``/seq``            (T,)                int64      1        device frame sequence number (unwrapped,
                                                            protocol v2); -1 = unknown (protocol v1)
``/device_time_us`` (T,)                int64      us       device clock (unwrapped ``t_us``); -1 = unknown
``/counters``       (4,)                int64      1        reader error counters, names in the attribute
                                                            ``names``: dropped_frames, bad_frames,
                                                            resyncs, bytes_discarded
``/crc32/NAME``     (ceil(T/c),)        uint32     1        CRC-32 of each chunk of ``/NAME`` (the frame
                                                            dataset and the four above); attribute
                                                            ``chunk_frames`` = c; no filter, so a damaged
                                                            entry costs its own chunk only
``/products/NAME``  any                 any        any      processed product (e.g. G, g, pressure, cop),
                                                            Fletcher-32 when it has elements; its CRC-32
                                                            (and ``/counters``') in the attribute ``crc32``
``/events/``        group                                   events (markers) of the recording (below); only
                                                            when it has any
``/streams/NAME/``  group                                   another device of the same recording (below)
==================  ==================  =========  =======  ==============================================

Streams (format version 3). A session that recorded several devices (``psmat record PORT
--also imu=PORT2``) keeps the first one at the root as above and each other one in a group
``/streams/NAME`` (``NAME`` an ASCII identifier, e.g. ``imu``, not one of the names of this
layout), holding the same per-frame datasets with the same chunking and Fletcher-32 checksums:

=============================  ===========  ===================================================
in ``/streams/NAME/``          shape        content
=============================  ===========  ===================================================
``counts``, ``angles`` or      (T_k, ...)   the stream's frames, as the root's for its kind
``samples``
``host_time_s``                (T_k,)       host clock when received, the same clock as ``/host_time_s``
``valid``, ``seq``,            (T_k,)       as at the root
``device_time_us``
``counters``                   (4,)         the stream's reader error counters
``crc32/NAME``                 (⌈T_k/c⌉,)   CRC-32 per chunk of the stream's datasets, as at the root
``device`` (group)                          the stream's device description (``json`` attribute)
=============================  ===========  ===================================================

Attributes of ``/streams/NAME``: ``kind``, ``frame_shape``, ``frame_dataset``, ``n_frames``.
A stream of kind ``lsl`` (``psmat record --lsl NAME``) holds the samples of a Lab Streaming Layer
stream: ``host_time_s`` its samples' LSL timestamps mapped to the host clock
(:class:`psmat.acquire.LslInlet`), ``valid`` 1, ``seq`` -1 (LSL numbers no samples),
``device_time_us`` the LSL timestamp on the sender's clock (µs); its device dict holds the LSL
stream's name, type, source id, nominal rate, channel labels and units, and the clock offsets used.
Metadata and calibration are the root's; products live at the root. A file with streams
has ``format_version`` 3, so that a psmat that knows only version 2 refuses it instead of
loading the first device and silently leaving the others out; a one-device file stays
version 2.

Imported pressure (kind ``pressure``, ``psmat import``). A session made from another maker's mat
(a Tekscan ASCII export, an XSENSOR CSV export, a generic CSV) holds that software's pressure in
kPa as its frames (``/pressure``, float32; :attr:`Session.frames`, also named ``counts`` as for
every kind), with the same per-frame datasets, checksums, journal and loader as a recording:
``host_time_s`` is the frame's time from the first frame (s, from the file), ``valid`` 1, ``seq``
and ``device_time_us`` -1. ``/profile`` is a profile of kind ``pressure`` (protocol ``import``, the
geometry: shape and pitch; no circuit); ``/metadata`` holds ``source_format``, ``source_file``,
``source_unit`` and the sensel size ``sensel_width_cm``, ``sensel_height_cm``.

Events (markers: ``SessionWriter.add_event(host_time_s, label)``, loaded sorted by time as
``Session.events``, a list of (host time s, label)). The group ``/events`` (attribute
``n_events`` = E) holds plain numbers only, as every dataset of a session does:

=============================  ===========  ========  =====  ======================================
in ``/events/``                shape        dtype     unit   content
=============================  ===========  ========  =====  ======================================
``host_time_s``                (E,)         float64   s      host clock of each event, the clock of
                                                             ``/host_time_s``; sorted
``label_utf8``                 (E, W)       uint8     1      each label's UTF-8 bytes (at most 200),
                                                             NUL padded to W, the longest label's
``crc32/host_time_s``,         (⌈E/e⌉,)     uint32    1      CRC-32 per chunk of ``e = min(64, E)``
``crc32/label_utf8``                                         events (attribute ``chunk_events`` = e)
=============================  ===========  ========  =====  ======================================

Both datasets are chunked ``e`` events a chunk with Fletcher-32, like the frames: a damaged
chunk costs its ``e`` events (left out, noted), no more. Labels are fixed-width rows rather than
one byte array with offsets so that a chunk of labels and a chunk of times hold the same events.
An older psmat ignores the group (and loads the file without its events); neither ``/events``
nor ``/profile`` changes ``format_version``.

Attributes of ``/`` (the root group): ``format`` = ``"psmat-session"``, ``format_version``
(int: 2, or 3 with ``/streams``), ``kind`` (``"psm"``, ``"imu"``, ``"daq"``, ``"lsl"`` or ``"pressure"``), ``frame_shape``
(int array), ``frame_dataset`` (``"counts"``, ``"angles"``, ``"samples"`` or ``"pressure"``), ``created_utc`` (ISO 8601),
``psmat_version``, ``complete`` (1), ``n_frames``, ``closed_utc``; after
:func:`repair_session` also ``repaired_utc`` and ``repair_notes``.

Groups ``/device``, ``/calibration`` (only when one was used), ``/metadata`` and ``/profile``
(the device profile the recording was made with, ``psmat.Profile.to_dict()``: shape, pitch,
geometry, wire order, circuit; only when one was given, :attr:`Session.profile` is None
otherwise): the attribute ``json`` holds the whole dictionary as a JSON string (the authoritative copy);
every scalar, string or flat numeric-list entry is also an attribute of its own, so that
``h5dump -A`` shows e.g. ``/device`` ``serial``, ``r_o``, ``v_ref``, ``bits``, ``fw``,
``protocol``, ``rate``, ``shape``.

Each ``/products/NAME`` dataset has attributes ``unit``, ``params_json`` (the parameters
that made it, JSON), the scalar parameters as attributes of their own, and ``created_utc``.

Format 1 (psmat before the checksums) had no Fletcher-32 filter and a ``/committed``
dataset; :func:`load_session` still reads it, with a note that its frames are unchecked.
Files of a psmat before the CRC-32 tables (same format versions: the tables are an addition
an older reader ignores) load with a note that they carry Fletcher-32 only.

A file received from elsewhere is untrusted (:mod:`._storage`; ``/profile`` and ``/events`` are
groups and datasets of numbers like the rest, checked the same way): before any data is
read, the loader refuses anything but groups and plain datasets of numbers stored in the
file (external storage, virtual datasets, soft and external links, filters other than
Fletcher-32), frame and per-frame datasets whose dtype, rank or frame shape is not the kind's,
lengths that disagree, and extents whose chunks are not stored; what it allocates is bounded
by the file's size.

Order in the file, so that a copy cut short loses trailing frames only (:mod:`._truncated`):
all HDF5 metadata first (one metadata block at the start, sized for the whole file, chunk
indexes included), then the CRC-32 tables, counters and products, then the frames' chunks
in frame order (chunk ``k`` of every per-frame dataset before chunk ``k + 1`` of any; the root
device, then each stream). A file shorter than its superblock records is loaded with the
missing tail read as zeros: the chunks not wholly before the cut are lost (their frames
invalid, noted ``file truncated at byte N of M: frames a..b lost``; with a journal beside it, the
journal is loaded instead); a cut before the first frame's chunk is one
:class:`SessionFormatError`. A product saved later (:func:`save_product`, :func:`save_products`)
is written into a copy of the file that replaces it when complete (the recording is never
modified in place); its metadata lands after the frames, where a cut costs the whole file.

Crash safety: one mechanism, the journal
========================================

docs/spec.md §6 promises that a recording killed at any moment loads with every frame whose
append had returned, and that a damaged byte costs at most the record or chunk it sits in.
Both promises are kept by the **journal** ``PATH.journal`` (format: :mod:`._journal`): a
CRC'd header, then one fixed-size CRC'd record per frame, written with ``os.write``
*before* :meth:`SessionWriter.append` returns (so it is in the operating system's cache
and survives the process being killed) and fsync'd every ``flush_interval_s`` /
``flush_frames`` (so it survives a power cut up to the last sync). The loader checks each
record's CRC-32 and skips a damaged one, going on with the next (records have one size).

The HDF5 file is written once, when the writer closes: the journal is read back record by
record into ``PATH.partial``, which is marked complete, fsync'd, read back and checked against
the journal's frames (frame counts, every chunk's CRC-32: :mod:`._verify`) and only
then renamed over ``PATH``; then the journal is removed (on a difference the journal stays and
:meth:`SessionWriter.close` raises). So ``PATH`` exists only complete, and an interrupted recording
is its journal alone (:func:`load_session` reads it, :func:`repair_session` turns it into
the file). Format 1 also wrote the HDF5 file in SWMR mode during the recording; that was
dropped: it could not hold the first promise alone (frames between flushes live only in
the journal), and reading a killed SWMR file meant parsing the superblock by hand and
matching HDF5's error strings, while the journal is plain bytes with a CRC per record.

Each stream has a journal of its own, ``PATH.NAME.journal``, of the same format, written by
its own :class:`StreamWriter` (so the reader threads of two devices never wait for each
other, and every record of a journal has one size, which is what lets the loader skip
exactly one damaged record); its header names the stream and carries the recording's random
id, which ties it to ``PATH.journal``. A killed recording loads from the root
journal and every stream journal tied to it; :func:`repair_session` writes them all into
the file; a stream journal whose header is unreadable is left out with a note.

The device profile travels in the root journal's header (key ``profile``; a journal of a psmat
before profiles has none and loads with ``profile`` None). Events have a journal of their own,
``PATH.events.journal`` (format: :mod:`._events`), created with the first event: a CRC'd
header carrying the recording's id (so an events journal of another recording is never taken
for this one's), then one fixed-size CRC'd record of 220 bytes per event (time, label length,
the label padded to 200 bytes), written and fsync'd before :meth:`SessionWriter.add_event`
returns. Why not records in the frame journal: its records have the size of one frame (a
10-sensor DAQ frame is 20 bytes), too small for a 200-byte label, and a record of another size
there would break the one-size rule that lets the loader skip exactly one damaged record; a
file and lock of their own also keep a thread marking events from waiting on the reader
threads. The loader skips a damaged event record as it skips a frame record (by the framing: a
tag byte, the length, six zero bytes, then the CRC), so a flipped byte costs that event only.
When the writer closes, the events journal is read back, its events written sorted into
``/events`` and checked with the frames, then removed; :func:`repair_session` keeps the events
of a killed recording.
"""

from ._counts import RowCounts, RowTally, row_counts
from ._events import MAX_LABEL_BYTES
from ._export import export_csv, info, stream_csv_path
from ._export_formats import export
from ._journal import Journal
from ._layout import (
    COUNTER_NAMES,
    FORMAT_NAME,
    FORMAT_VERSION,
    STREAMS_FORMAT_VERSION,
    Product,
    Session,
    SessionFormatError,
    journal_path,
    psmat_version,
)
from ._products import save_product, save_products
from ._reader import load_session, repair_session, replacement_journal
from ._sample import host_time_span, sample_frames, utc_offset_of
from ._truncated import recorded_size
from ._unfinished import journal_only, not_closed_line, session_files, unfinished_line, unfinished_reason
from ._writer import SessionNotCompleted, SessionWriter, StreamWriter

__all__ = [
    "COUNTER_NAMES",
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "STREAMS_FORMAT_VERSION",
    "Journal",
    "Product",
    "RowCounts",
    "RowTally",
    "Session",
    "SessionFormatError",
    "MAX_LABEL_BYTES",
    "SessionNotCompleted",
    "SessionWriter",
    "StreamWriter",
    "export",
    "export_csv",
    "info",
    "journal_only",
    "journal_path",
    "load_session",
    "not_closed_line",
    "psmat_version",
    "recorded_size",
    "repair_session",
    "replacement_journal",
    "row_counts",
    "sample_frames",
    "host_time_span", "utc_offset_of",
    "save_product",
    "save_products",
    "session_files",
    "stream_csv_path",
    "unfinished_line",
    "unfinished_reason",
]
