"""SCHC-DYN's per-session part as tasks of a run's pool or cluster (docs/spec.md §12).

After the sessions, :func:`psmat.study.plan_dynamic` fits every fold's correction from the
statistics the session tasks stored (a few small solves, in the run's process); what is left is
each session's own work — read its traces, resample, correct, its sway metrics and descriptors —
which :func:`psmat.study.correct_session` does for one session. Here that work is grouped in one
:class:`DynamicTask` per volunteer, which the pool's processes or the cluster's workers run; it
carries the traces files' paths (a cluster's workers must share the study's filesystem, as
for the sessions) and the fitted corrections, and returns each session's row and corrected
trace.

From a cluster the answer comes back as data (:func:`encode_dynamic`: an ``.npz`` with the rows
as JSON and the corrected traces as float64 arrays, nothing pickled) and is checked before use
(:func:`decode_dynamic`: the volunteer, trials and variant, the columns and their types, each
trace's shape against the session's own trace); an answer refused or lost is computed in this
process instead, so the rows never depend on which worker answered.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._dynamic import Correction, DynamicPlan, correct_session
from ._plain import STATS_PREFIX, check_row, digest, encode_plain, plain_rows, read_result
from ._timings import TaskTime
from ._trial import COLUMNS

__all__ = ["RunDynamic", "DynamicTask", "dynamic_tasks", "run_dynamic", "encode_dynamic", "decode_dynamic", "task_key",
           "trace_lengths"]

#: one session of a task: its trial, traces file, base row and the correction fitted without its volunteer
Session = tuple[str, str, Mapping[str, Any], Correction]
#: one session's answer: its trial, its ``<base>-DYN`` row and corrected trace ((N, 2) cm, or None)
Answer = tuple[str, dict[str, Any], "NDArray[np.float64] | None"]
#: runs a run's SCHC-DYN tasks: (task, its answers, its time in the worker or None) as each is done
RunDynamic = Callable[[list["DynamicTask"]], Iterator[tuple["DynamicTask", list[Answer], TaskTime | None]]]


@dataclass(frozen=True)
class DynamicTask:
    """One volunteer's sessions to correct, with what :func:`psmat.study.correct_session` needs."""

    subject: str
    sessions: tuple[Session, ...]
    rate_hz: float  # the fitting rate, Hz
    base: str
    preprocess: str | None
    descriptors: str | None


def dynamic_tasks(plan: DynamicPlan, files: Mapping[tuple[str, str], Path], *, base: str = "SCHC",
                  preprocess: str | None = None, descriptors: str | None = None) -> list[DynamicTask]:
    """The plan's corrections, one task per volunteer (in the plan's order); ``files``: each
    session's traces file (``.npz``)."""
    by_subject: dict[str, list[Session]] = {}
    for (subject, trial), (row, corr) in plan.jobs.items():
        by_subject.setdefault(subject, []).append((trial, str(files[(subject, trial)]), dict(row), corr))
    return [DynamicTask(s, tuple(v), plan.rate_hz, base, preprocess, descriptors) for s, v in by_subject.items()]


def _traces(path: str) -> dict[str, NDArray[np.float64]]:
    with np.load(path) as z:
        return {k: z[k] for k in z.files if not k.startswith(STATS_PREFIX)}


def run_dynamic(task: DynamicTask) -> list[Answer]:
    """Correct each session of ``task`` (in whichever process runs it)."""
    out: list[Answer] = []
    for trial, path, row, corr in task.sessions:
        new, c = correct_session(_traces(path), row, corr, task.rate_hz, base=task.base, preprocess=task.preprocess,
                                 descriptors=task.descriptors)
        out.append((trial, new, c))
    return out


def task_key(task: DynamicTask, *, file_names: bool = False) -> str:
    """A digest of everything the task's answer depends on (its Dask key). ``file_names``: the
    traces files by name (they carry their session's key) instead of by path, so that the key
    outlives a move of the study's folder (the key kept on disk, psmat.study._dynamic_cache)."""
    parts: list[str | bytes] = [task.subject, repr(task.rate_hz), task.base, repr(task.preprocess), repr(task.descriptors)]
    for trial, path, row, corr in task.sessions:
        parts += [trial, Path(path).name if file_names else path, json.dumps(plain_rows([row])), corr.model,
                  repr(corr.rate_hz),
                  *(np.asarray(c, np.float64).tobytes() for c in corr.coef)]
    return digest(*parts)


def trace_lengths(task: DynamicTask) -> dict[str, int]:
    """Each trial's trace length (samples) from its own traces file: the shape in the header of
    its ``t_s`` array, the array itself not read (what :func:`decode_dynamic` checks against)."""
    out = {}
    for trial, path, _, _ in task.sessions:
        with np.load(path) as z:
            with z.zip.open("t_s.npy") as fh:
                major, _ = np.lib.format.read_magic(fh)
                if major in (1, 2):
                    read = np.lib.format.read_array_header_1_0 if major == 1 else np.lib.format.read_array_header_2_0
                    shape, _, _ = read(fh)
                else:  # a header version without a public reader: the array itself
                    shape = z["t_s"].shape
        if len(shape) != 1:
            raise ValueError(f"{Path(path).name}: t_s of shape {shape}")
        out[trial] = int(shape[0])
    return out


def encode_dynamic(task: DynamicTask, answers: Iterable[Answer]) -> bytes:
    """A task's answers as ``.npz`` bytes: the rows as JSON, trace ``i`` as the array ``c<i>``."""
    answers = list(answers)
    return encode_plain({"subject": task.subject, "rows": plain_rows([r for _, r, _ in answers])},
                        {f"c{i}": c for i, (_, _, c) in enumerate(answers) if c is not None})


def decode_dynamic(data: Any, task: DynamicTask, lengths: Mapping[str, int]) -> list[Answer]:
    """:func:`encode_dynamic`'s bytes → the task's answers, checked.

    ``lengths``: each trial's trace length (samples), read from its own traces file here.

    Raises
    ------
    ValueError
        Not such bytes; another volunteer; not one row per session with exactly the base row's
        columns (text and numbers where they belong, :func:`psmat.study._plain.check_row`), its
        subject, trial and variant ``<base>-DYN``, for the whole trial; a status other than
        ``ok`` (with its trace) or ``not corrected: ...`` (without one); a trace not float64 of
        shape (N, 2), N the session's own.
    """
    doc, arrays = read_result(data)
    if not isinstance(doc, dict) or set(doc) != {"subject", "rows"} or not isinstance(doc["rows"], list):
        raise ValueError("the result's JSON is not {subject, rows}")
    if doc["subject"] != task.subject:
        raise ValueError(f"a result for {doc['subject']!r}, expected {task.subject!r}")
    if len(doc["rows"]) != len(task.sessions):
        raise ValueError(f"{len(doc['rows'])} rows for {len(task.sessions)} sessions")
    name = f"{task.base}-DYN"
    out: list[Answer] = []
    expected: set[str] = set()
    for i, ((trial, _, base_row, _), value) in enumerate(zip(task.sessions, doc["rows"])):
        row = check_row(value, tuple(dict.fromkeys((*COLUMNS, *base_row))), i)
        if (row["subject"], row["trial"], row["variant"], row["condition"]) != (task.subject, trial, name, ""):
            raise ValueError(f"row {i} is not {name} of {task.subject} {trial} for the whole trial")
        ok = row["status"] == "ok"
        if not ok and not row["status"].startswith("not corrected: "):
            raise ValueError(f"row {i}: status {row['status']!r}")
        c = None
        if ok:
            expected.add(f"c{i}")
            c = arrays.get(f"c{i}")
            if c is None or c.dtype != np.float64 or c.shape != (lengths[trial], 2):
                raise ValueError(f"trace {i}: not float64 of shape ({lengths[trial]}, 2)")
        out.append((trial, row, c))
    if set(arrays) != expected:
        raise ValueError(f"arrays {sorted(set(arrays) - expected)} that no row corrected")
    return out
