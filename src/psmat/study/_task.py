"""One session of a study as a task that any worker runs (a process of this machine or a Dask
worker): plain values in, plain rows and traces out (:func:`run_task`), and the rows that stand
for a session without numbers (:func:`status_rows`, :func:`error_rows`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ._dynamic import session_stats
from ._plain import STATS_PREFIX, Expect
from ._row_metrics import columns
from ._trial import COLUMNS, Rows, Traces, process_trial

__all__ = ["SessionTask", "run_task", "status_rows", "error_rows"]


@dataclass(frozen=True)
class SessionTask:
    """One session as a task: plain values only, so it travels to any worker by pickle."""

    stem: str
    session: str
    forceplate: str | None
    subject: str
    trial: str
    weight_kg: float | None
    calibration: str | None
    params: dict[str, Any]
    key: str
    inputs: dict[str, Any]
    notes: tuple[str, ...] = ()
    #: markers (host time s, label) from the study's ``events/<stem>.csv``; None: the session's own
    events: tuple[tuple[float, str], ...] | None = None

    @property
    def expect(self) -> Expect:
        """What this session's result must be (checked when it is read back or received)."""
        return Expect(self.stem, self.subject, self.trial, tuple(self.params["variants"]),
                      columns(COLUMNS, self.params))


def run_task(task: SessionTask) -> tuple[str, Rows, Traces]:
    """Process one session (in whichever process runs it): (stem, rows, traces).

    With ``SCHC`` among the variants, the traces also hold ``stats:<name>`` arrays
    (:data:`STATS_PREFIX`): the session's own part of the ``SCHC-DYN`` fit
    (:func:`psmat.study.session_stats`), formed here so the study's work after the sessions is
    the fits alone; they are stored with the session's result and reused by a rerun.
    """
    rows, traces = process_trial(task.session, task.forceplate, task.subject, task.trial, task.weight_kg,
                                 task.params, calibration=task.calibration, traces=True,
                                 events=task.events)
    if "SCHC" in task.params["variants"] and traces:
        traces.update({STATS_PREFIX + k: v for k, v in session_stats(traces, base="SCHC").items()})
    return task.stem, rows, traces


def status_rows(t: SessionTask, status: str) -> Rows:
    """A row per variant (and FP) of ``t`` with no numbers and this status."""
    return [{**dict.fromkeys(columns(COLUMNS, t.params), math.nan), "subject": t.subject, "trial": t.trial,
             "variant": v, "condition": "", "ispgr": "", "status": status} for v in ("FP", *t.params["variants"])]


def error_rows(t: SessionTask, exc: BaseException) -> Rows:
    """The rows of a session whose processing raised ``exc``: status ``error: <type>: <message>``."""
    return status_rows(t, f"error: {type(exc).__name__}: {exc}".replace("\n", " "))
