"""Where a study run's time goes: ``results/timings.csv`` and ``results/session_timings.csv``
(docs/spec.md §12), written atomically by every ``psmat study run``.

``timings.csv`` has one row per stage, in the order they run:

* ``discover`` — finding the study's files, reading ``subjects.csv``, the calibrations;
* ``keys`` — each session's key (the SHA-256 of its inputs' bytes) and the stored results
  proven against it (:mod:`psmat.study` (``_cache.py``));
* ``sessions`` — the session tasks, from the pool's start (or the connection to the Dask
  scheduler) to the last session's result; on a first run the pool's processes are started
  before ``discover`` and this stage begins with what is left of their start-up; ``cpu_s`` is the sum of the tasks' CPU time in the
  processes that ran them;
* ``reports`` — with ``--reports``: the pages still running after the last session (the pages are
  tasks of the same pool or cluster; without ``--reports``, the pool's shutdown); ``cpu_s``
  summed from their workers;
* ``after_sessions`` — SCHC-DYN across volunteers (its fits here, each volunteer's corrections
  as tasks of the pool or cluster: ``cpu_s`` adds their workers'; ``computed`` and ``reused``
  count the volunteers whose corrections were made now or read back from ``results/dynamic``),
  ``metrics.csv``, the summary tables and the check of ``results/.outputs.json``;
* ``figures`` and ``report`` — the figures (tasks of the pool or cluster; ``cpu_s`` adds their
  workers') and ``report.md`` (0 when reused unchanged).

Columns: ``stage``, ``wall_s`` (s, this process's clock), ``cpu_s`` (s: this process's CPU time,
or for ``sessions``/``reports`` the workers' summed), ``computed`` and ``reused`` (how many
sessions, pages, volunteers' SCHC-DYN corrections, figures or reports were made now or found up
to date; empty where it does not apply). ``session_timings.csv``: one row per session — ``subject``, ``trial``, ``stem``,
``result`` (``computed``, ``reused``, ``failed`` or ``not closed``), ``start_s`` (s after the run
began that the task started in its worker: a worker's start-up delays its first task),
``wall_s`` and ``cpu_s`` of the task in its worker (CPU: :func:`time.process_time` of the worker's
whole process over the task), the worker's ``pid``, and ``worker``: the Dask worker's address
(``tcp://host:port``) when a cluster ran it, empty for a process of this machine; the time
columns are empty for a session not computed now.

On a Dask cluster each task sends its time back beside its result, as plain numbers and text
checked like the result (:func:`psmat.study._plain.check_timed`); ``start_s`` is then read on
the worker's clock, so across machines it is as good as their clocks agree, and a worker running
several tasks at once (``--nthreads`` above 1) counts their CPU time in each other's.

Neither file is an input of any key or of the outputs' digest: a rerun rewrites only them.
"""

from __future__ import annotations

import contextlib
import csv
import io
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from .._atomic import write_text_atomic

__all__ = ["Stopwatch", "PoolClock", "TaskTime", "timed", "STAGES", "STAGE_COLUMNS", "SESSION_COLUMNS"]

#: the stages of a run, in order (docs/spec.md §12)
STAGES = ("discover", "keys", "sessions", "reports", "after_sessions", "figures", "report")
STAGE_COLUMNS = ("stage", "wall_s", "cpu_s", "computed", "reused")
SESSION_COLUMNS = ("subject", "trial", "stem", "result", "start_s", "wall_s", "cpu_s", "pid", "worker")

R = TypeVar("R")


@dataclass(frozen=True)
class TaskTime:
    """One task's time in the process that ran it: its start (s since the epoch, wall clock
    comparable across processes), its wall and CPU seconds, the process id, and the Dask
    worker's address ("" for a process of this machine)."""

    start: float
    wall_s: float
    cpu_s: float
    pid: int
    worker: str = ""


def timed(fn: Callable[[Any], R], arg: Any) -> tuple[R, TaskTime]:
    """``fn(arg)`` and the time it took in this process (CPU: :func:`time.process_time`, the
    whole process's, so it counts the tasks of a worker that runs one at a time)."""
    start, w0, c0 = time.time(), time.perf_counter(), time.process_time()
    out = fn(arg)
    return out, TaskTime(start, time.perf_counter() - w0, time.process_time() - c0, os.getpid())


@dataclass
class _Stage:
    wall_s: float = 0.0
    cpu_s: float = 0.0
    computed: int | None = None
    reused: int | None = None


@dataclass
class Stopwatch:
    """The stages of one run and its sessions' task times (written by :meth:`write`)."""

    start: float = field(default_factory=time.time)
    stages: dict[str, _Stage] = field(default_factory=lambda: {s: _Stage() for s in STAGES})
    sessions: list[tuple[str, str, str, str, TaskTime | None]] = field(default_factory=list)

    _open: dict[str, tuple[float, float]] = field(default_factory=dict)

    def begin(self, name: str) -> None:
        """Start (again) the clock of stage ``name``: wall and this process's CPU time."""
        self._open[name] = (time.perf_counter(), time.process_time())

    def end(self, name: str) -> None:
        """Add the time since :meth:`begin` to stage ``name``."""
        w0, c0 = self._open.pop(name)
        self.add(name, time.perf_counter() - w0, time.process_time() - c0)

    def add(self, name: str, wall_s: float, cpu_s: float) -> None:
        """Add ``wall_s`` and ``cpu_s`` (s) to stage ``name``."""
        s = self.stages[name]
        s.wall_s += wall_s
        s.cpu_s += cpu_s

    @contextlib.contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Add the time of the ``with`` block to stage ``name``."""
        self.begin(name)
        try:
            yield
        finally:
            self.end(name)

    def count(self, name: str, computed: int, reused: int) -> None:
        """What stage ``name`` made now and found up to date."""
        s = self.stages[name]
        s.computed, s.reused = computed, reused

    def session(self, subject: str, trial: str, stem: str, result: str, took: TaskTime | None = None) -> None:
        """One session's line: how its result was had, and its task's time when computed here."""
        self.sessions.append((subject, trial, stem, result, took))

    def write(self, results: Path) -> tuple[Path, Path]:
        """``results/timings.csv`` and ``results/session_timings.csv``, each atomically."""
        rows = [[name, _num(s.wall_s), _num(s.cpu_s), _opt(s.computed), _opt(s.reused)]
                for name, s in self.stages.items()]
        srows = [[subject, trial, stem, result, *(("",) * 5 if t is None else
                                                  (_num(max(0.0, t.start - self.start)), _num(t.wall_s),
                                                   _num(t.cpu_s), str(t.pid), t.worker))]
                 for subject, trial, stem, result, t in sorted(self.sessions)]
        out = results / "timings.csv", results / "session_timings.csv"
        write_text_atomic(out[0], _csv(STAGE_COLUMNS, rows))
        write_text_atomic(out[1], _csv(SESSION_COLUMNS, srows))
        return out


class PoolClock:
    """The pool's wall time split at its last session's result (``sessions``, then ``reports``:
    the pages still running), and the CPU seconds the workers report for each kind of task."""

    def __init__(self, clock: Stopwatch) -> None:
        self._clock = clock
        self._t0 = self._last = time.perf_counter()
        self._cpu = {"session": 0.0, "report": 0.0}

    def add(self, kind: str, took: TaskTime | None) -> None:
        """A task of ``kind`` (``"session"`` or ``"report"``) came back, with its time or None."""
        if kind == "session":
            self._last = time.perf_counter()
        if took is not None:
            self._cpu[kind] += took.cpu_s

    def stop(self) -> None:
        """The pool is done: add its two parts to the run's stages."""
        end = time.perf_counter()
        self._clock.add("sessions", self._last - self._t0, self._cpu["session"])
        self._clock.add("reports", end - self._last, self._cpu["report"])


def _num(x: float) -> str:
    return f"{max(0.0, x):.4f}"


def _opt(n: int | None) -> str:
    return "" if n is None else str(n)


def _csv(cols: tuple[str, ...], rows: list[list[str]]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    w.writerows(rows)
    return buf.getvalue()
