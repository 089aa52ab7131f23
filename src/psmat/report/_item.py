"""What a report is asked about (:class:`ReportItem`) and its options (:data:`DEFAULT_PARAMS`)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["ReportItem", "DEFAULT_PARAMS", "merged_params"]

#: a report's options; ``write_report(params=...)`` overrides them by name
DEFAULT_PARAMS: dict[str, Any] = {
    "preset": "quijoux2021",     # preprocessing of every CoP trace before its metrics (psmat.balance.preprocess)
    "threshold_kpa": 5.0,        # a cell is loaded above this pressure, for the regions (kPa)
    "method": "newton",          # IECM method of a mat session's chain
    "calibration": None,         # a calibration file for the mat sessions (psmat calibrate, JSON)
    "max_lag_s": None,           # largest lag searched when aligning with a platform (s); None: any
    "platform_axes": "x,y",      # how the platform's axes lie on the mat's (psmat.balance.PLATFORM_AXES)
    "ispgr_min_duration_s": 25.0,  # ISPGR (Scoppa et al. 2013): a trial lasts at least this (s)
    "ispgr_min_rate_hz": 50.0,   # ... sampled at least this fast (Hz)
}


@dataclass(frozen=True)
class ReportItem:
    """One session of a report.

    Parameters
    ----------
    session : path
        The session file (``.h5``): a mat (``psm``) session or an imported ``"pressure"`` one.
    platform : path, optional
        A force-platform CSV of the same trial (:func:`psmat.io.load_forceplate_csv`), aligned with
        the mat's CoP.
    label : str
        The section's title; default the file's name.
    events : sequence of (float, str), optional
        Markers to use instead of the session's own (e.g. :func:`psmat.balance.load_events_csv`).
    events_from_start : bool
        ``events`` times are seconds from the session's first frame; False (default): on the
        session's host clock, as ``psmat export S.h5 --what events`` writes them.
    """

    session: str | os.PathLike[str]
    platform: str | os.PathLike[str] | None = None
    label: str = ""
    events: Sequence[tuple[float, str]] | None = None
    events_from_start: bool = False


def merged_params(params: dict[str, Any] | None) -> dict[str, Any]:
    """:data:`DEFAULT_PARAMS` with ``params`` over them; an unknown name is one ValueError line."""
    unknown = sorted(set(params or {}) - set(DEFAULT_PARAMS))
    if unknown:
        raise ValueError(f"unknown report parameter(s) {', '.join(unknown)}; known: {', '.join(DEFAULT_PARAMS)}")
    return {**DEFAULT_PARAMS, **(params or {})}
