"""Recorded sessions and external data files (docs/spec.md §6).

* :mod:`psmat.io.session` — a recording as one HDF5 file (raw frames, timing, validity,
  device, calibration, metadata, processed products; several devices as streams on one
  host clock), crash-safe while it is written.
* :mod:`psmat.io.imu_log` — the spine IMUs' text logs (the thesis' format).
* :mod:`psmat.io.forceplate` — force-platform centre-of-pressure files (generic CSV and
  the BDS public data set).
"""

from .forceplate import (
    ForcePlateRecording,
    bds_dir,
    bds_files,
    bds_trial,
    bds_trials_table,
    load_bds,
    load_forceplate_csv,
)
from .imu_log import ImuLog, load_imu_log, write_imu_log
from .session_counts import RowCounts, RowTally, row_counts
from .session import (
    COUNTER_NAMES,
    FORMAT_NAME,
    FORMAT_VERSION,
    STREAMS_FORMAT_VERSION,
    Product,
    Session,
    SessionFormatError,
    SessionWriter,
    StreamWriter,
    export_csv,
    info,
    journal_path,
    load_session,
    repair_session,
    save_product,
    save_products,
    stream_csv_path,
)

__all__ = [
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
    "SessionWriter",
    "STREAMS_FORMAT_VERSION",
    "StreamWriter",
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
