"""SCHC-DYN's answers kept between runs (docs/spec.md §12): a rerun whose fits and traces are those
of an earlier run reads each volunteer's ``<base>-DYN`` rows and corrected traces back instead of
computing them again.

One file per volunteer, ``DIR/results/dynamic/<v>.npz`` (``v``: the first 16 hex digits of the
SHA-256 of the volunteer's name, a safe file name for any name), holding

* ``key`` (text): ``digest(SCHEMA, the session results' schema, psmat's version, task_key)``,
  where :func:`psmat.study._dynamic_tasks.task_key` (``file_names=True``) digests everything a
  volunteer's answer depends on: the corrections fitted without the volunteer, each session's
  base row and the name of its traces file (which carries the session's key, so new traces are a
  new name; a study folder moved elsewhere keeps its keys), the fitting rate, the preprocessing
  and the descriptors asked for;
* ``answer`` (bytes, ``uint8``): :func:`psmat.study._dynamic_tasks.encode_dynamic`'s ``.npz``
  bytes (the rows as JSON, the traces as float64 arrays, nothing pickled);
* ``digest`` (text): ``digest(key, answer)`` (:func:`psmat.study._plain.digest`: each part
  length-prefixed).

A file whose key differs from the current task's is stale and is rewritten quietly. One with the
current key is used only if it opens (NumPy, ``allow_pickle=False``), holds exactly these entries,
lies inside ``DIR/results`` once links are resolved, its digest matches and its answer passes
:func:`psmat.study._dynamic_tasks.decode_dynamic`'s checks (the volunteer, one row per session with
the base row's columns and types, the variant, each trace float64 of the session's own length);
anything else is computed again, rewritten and said among
the run's problems, never trusted and never fatal. The digest detects corruption and edits, not a
forger: whoever can write ``results/`` can write ``metrics.csv``. Each file is written whole or not
at all (:func:`psmat._atomic.open_atomic`), as soon as its volunteer's answer is in: a killed run
keeps what it finished.

A changed session changes the fits of every other volunteer (each is fitted on the others), so
a rerun after one changed volunteer computes them all again; a rerun with nothing changed
computes none.
"""

from __future__ import annotations

import hashlib
import io
import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from .._atomic import open_atomic, remove_temporaries
from .._version import __version__
from ._cache import SCHEMA as SESSION_SCHEMA
from ._dynamic_tasks import Answer, DynamicTask, RunDynamic, decode_dynamic, encode_dynamic, task_key, trace_lengths
from ._plain import StaleEntry, digest, first_line, npz_text
from ._timings import TaskTime

__all__ = ["SCHEMA", "DynamicStore"]

# bumped when what psmat.study.correct_session computes changes (the sway metrics and descriptors it
# shares with the sessions change the session results' SCHEMA, which is part of the key too)
SCHEMA = "psmat-study-dynamic/1"
_ENTRIES = frozenset({"key", "answer", "digest"})


class DynamicStore:
    """The volunteers' SCHC-DYN answers in ``results/dynamic`` (see the module docstring)."""

    def __init__(self, results: str | os.PathLike[str]) -> None:
        self.results = Path(results)
        self.folder = self.results / "dynamic"
        self.problems: list[str] = []  # files on disk that were not trusted, or not written
        self.computed = 0
        self.reused = 0

    def key(self, task: DynamicTask) -> str:
        """The key a stored answer of ``task`` must carry."""
        return digest(SCHEMA, SESSION_SCHEMA, __version__, task_key(task, file_names=True))

    def path(self, subject: str) -> Path:
        """The file of the volunteer ``subject``."""
        return self.folder / f"{hashlib.sha256(subject.encode()).hexdigest()[:16]}.npz"

    def load(self, task: DynamicTask) -> tuple[list[Answer] | None, str | None]:
        """(the stored answers, None) when they are proven to be ``task``'s; else (None, why not),
        why None when there is no file or it was made from other inputs."""
        path = self.path(task.subject)
        if not os.path.lexists(path):
            return None, None
        try:
            return self._verified(path, task), None
        except StaleEntry:
            return None, None
        except Exception as exc:  # noqa: BLE001 - zip, format, JSON, shape: whatever is wrong, recompute
            what = str(exc) if isinstance(exc, ValueError) else f"{type(exc).__name__}: {exc}"
            return None, (f"{task.subject}: stored SCHC-DYN answer dynamic/{path.name} not used "
                          f"({first_line(what)}); computed again")

    def _verified(self, path: Path, task: DynamicTask) -> list[Answer]:
        real = path.resolve()
        if not real.is_relative_to(self.results.resolve()):
            raise ValueError(f"it leads outside {self.results} (to {real}); not read")
        with open(real, "rb") as fh, np.load(fh, allow_pickle=False) as z:  # our handle: closed even on a bad zip
            arrays = {k: z[k] for k in z.files}
        if "key" not in arrays or npz_text(arrays, "key") != self.key(task):
            raise StaleEntry
        if set(arrays) != _ENTRIES:
            raise ValueError(f"entries {sorted(arrays)}, expected {sorted(_ENTRIES)}")
        answer = arrays["answer"]
        if answer.dtype != np.uint8 or answer.ndim != 1:
            raise ValueError("answer is not bytes")
        if npz_text(arrays, "digest") != digest(npz_text(arrays, "key"), answer.tobytes()):
            raise ValueError("digest mismatch: the file changed after it was written")
        return decode_dynamic(answer.tobytes(), task, trace_lengths(task))

    def save(self, task: DynamicTask, answers: list[Answer]) -> None:
        """Keep ``task``'s answers (whole or not at all); a file that cannot be written is a
        problem line, not the end of the run."""
        key = self.key(task)
        data = encode_dynamic(task, answers)
        buf = io.BytesIO()
        np.savez(buf, key=np.array(key), answer=np.frombuffer(data, np.uint8), digest=np.array(digest(key, data)))
        path = self.path(task.subject)
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            with open_atomic(path, "wb") as fh:
                fh.write(buf.getvalue())
        except OSError as exc:
            self.problems.append(f"{task.subject}: SCHC-DYN answer not kept in {path} ({exc.strerror or exc}); "
                                 "the next run computes it again")

    def around(self, run: RunDynamic) -> RunDynamic:
        """``run`` for the tasks without a proven stored answer; the others read back. Each answer
        computed is kept as it comes in."""

        def cached(tasks: list[DynamicTask]) -> Iterator[tuple[DynamicTask, list[Answer], TaskTime | None]]:
            if self.folder.is_dir() and (n := remove_temporaries(self.folder)):  # (the run holds the study's lock)
                self.problems.append(f"removed {n} incomplete temporary file(s) an interrupted run left in "
                                     f"{self.folder}")
            todo = []
            for task in tasks:
                answers, problem = self.load(task)
                if problem is not None:
                    self.problems.append(problem)
                if answers is None:
                    todo.append(task)
                    continue
                self.reused += 1
                yield task, answers, None
            if not todo:  # nothing to compute: no pool started, no cluster asked
                return
            for task, answers, took in run(todo):
                self.save(task, answers)
                self.computed += 1
                yield task, answers, took

        return cached
