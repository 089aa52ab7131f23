"""Recorded sessions and external data files (docs/spec.md §6).

* :mod:`psmat.io.session` — a recording as one HDF5 file (raw frames, timing, validity,
  device, calibration, metadata, device profile, events, processed products; several devices
  as streams on one host clock), crash-safe while it is written; :func:`export` writes its
  counts, pressure, CoP or events as CSV, Parquet or MATLAB files.
* the spine IMUs' text logs (the thesis' format): :func:`load_imu_log`, :func:`write_imu_log`
  (private module ``_imu_log``).
* other mats' pressure files (Tekscan ASCII export, XSENSOR CSV export, a generic CSV of one
  frame a line) as sessions of kind ``"pressure"``: :func:`import_pressure`,
  :func:`read_pressure_file` (private modules ``_import*``).
* :func:`frame_times`: frames of one serial chunk (one arrival time on the host) spread back by
  the device clock or the device's frame period (:func:`run_end_period_s`), private module
  ``_frame_times``.
* force-platform centre-of-pressure files (generic CSV and the BDS public data set):
  :func:`load_forceplate_csv`, :func:`load_bds`, :func:`bds_trial`, ... (private module
  ``_forceplate``).

The names below are this package's public API; :mod:`psmat.io.session` has a few more (the
journal, an unfinished recording's notes).
"""

from ._forceplate import (
    ForcePlateRecording,
    bds_dir,
    bds_files,
    bds_trial,
    bds_trials_table,
    load_bds,
    load_forceplate_csv,
)
from ._import import (IMPORT_FORMATS, ImportedFrames, ImportFormatError, detect_format, import_pressure,
                      read_pressure_file)
from ._frame_times import GAP_MIN_S, GAP_PERIODS, clock_restarts, frame_times, host_gaps, run_end_period_s, \
    streaming_period_s
from ._imu_log import ImuLog, load_imu_log, write_imu_log
from .session import (
    COUNTER_NAMES,
    FORMAT_NAME,
    FORMAT_VERSION,
    STREAMS_FORMAT_VERSION,
    Product,
    RowCounts,
    RowTally,
    Session,
    SessionFormatError,
    SessionNotCompleted,
    SessionWriter,
    StreamWriter,
    export,
    export_csv,
    info,
    journal_path,
    load_session,
    repair_session,
    row_counts,
    save_product,
    save_products,
    stream_csv_path,
)

__all__ = [
    "frame_times",
    "clock_restarts", "host_gaps", "streaming_period_s", "GAP_MIN_S", "GAP_PERIODS",
    "run_end_period_s",
    "IMPORT_FORMATS",
    "ImportedFrames",
    "ImportFormatError",
    "detect_format",
    "import_pressure",
    "read_pressure_file",
    "ImuLog",
    "load_imu_log",
    "write_imu_log",
    "COUNTER_NAMES",
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "ForcePlateRecording",
    "Product",
    "Session",
    "SessionFormatError",
    "SessionNotCompleted",
    "SessionWriter",
    "STREAMS_FORMAT_VERSION",
    "StreamWriter",
    "export",
    "bds_dir",
    "bds_files",
    "bds_trial",
    "bds_trials_table",
    "export_csv",
    "info",
    "journal_path",
    "load_bds",
    "load_forceplate_csv",
    "load_session",
    "repair_session",
    "row_counts",
    "RowCounts",
    "RowTally",
    "save_product",
    "save_products",
    "stream_csv_path",
]
