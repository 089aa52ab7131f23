"""One study session as the bench's plain tasks see it (no files written, no cache): the
arguments of :func:`psmat.study.process_trial` for each session of a study, and that function
run on them. Used by the baseline pool of ``python -m psmat.bench study`` and by its load probe
(:mod:`psmat.bench.load_probe`)."""

from __future__ import annotations

import os
import time
from typing import Any

__all__ = ["SessionArgs", "session_args", "process_one", "timed_one"]

#: (session file, force-platform file or None, subject, trial, body weight in kg or None)
SessionArgs = tuple[str, "str | None", str, str, "float | None"]


def session_args(layout: Any) -> list[SessionArgs]:
    """The arguments of :func:`psmat.study.process_trial` for each session of ``layout``
    (:func:`psmat.study.find_study`), in its order."""
    return [(str(i.session), None if i.forceplate is None else str(i.forceplate), i.subject or "", i.trial or "",
             None if i.subject not in layout.subjects else layout.subjects[i.subject].weight_kg)
            for i in layout.items]


def process_one(args: SessionArgs) -> int:
    """One session through the per-session function, nothing written; its row count."""
    from ..study import process_trial

    session, plate, subject, trial, weight = args
    return len(process_trial(session, plate, subject, trial, weight))


def timed_one(args: SessionArgs) -> tuple[float, float, float, float, int, int, float]:
    """:func:`process_one` timed in the process that runs it: (start and end on the machine's
    monotonic clock, s, comparable between its processes; wall and CPU time, s; the process id;
    the minor page faults and the system CPU time, s, it took: -1 where the platform has no
    ``resource`` module)."""
    try:
        import resource
    except ImportError:  # Windows
        resource = None  # type: ignore[assignment]
    r0 = resource.getrusage(resource.RUSAGE_SELF) if resource else None
    t0, c0 = time.monotonic(), time.process_time()
    process_one(args)
    t1 = time.monotonic()
    cpu = time.process_time() - c0
    if r0 is None or resource is None:
        return t0, t1, t1 - t0, cpu, os.getpid(), -1, -1.0
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    return t0, t1, t1 - t0, cpu, os.getpid(), r1.ru_minflt - r0.ru_minflt, r1.ru_stime - r0.ru_stime
