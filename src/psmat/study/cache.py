"""Per-session results of a study run on disk (docs/spec.md §12): keyed by content, written atomically.

``DIR/results/sessions/<stem>.json`` holds one session's rows and the inputs they were made
from; its traces (:func:`psmat.study.trial.process_trial` with ``traces=True``) are
``<stem>.<key16>.npz`` beside it. Both are plain files (JSON, NumPy ``.npz``) that any tool
reads. A result is reused only when its stored key equals the key of the current inputs:

``key = sha256(canonical JSON of {schema, psmat version, the whole parameter dict, the stem,
subject, trial, body weight, sha256 of the session file (and of its journal if one lies
beside it), of the platform file, of the study's calibration file if one is used})``

so a changed session, platform file, weight, calibration or parameter reruns exactly the
sessions it touches. Each file is written to a hidden temporary name, flushed to disk and
moved into place with :func:`os.replace`: a killed run leaves either the old result or the
new one, never half of one (the traces are moved first, the JSON that names them last).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import re
import tempfile
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np

from .._filelock import LockHeld, exclusive_lock
from .trial import COLUMNS, Rows, Traces

__all__ = ["SCHEMA", "file_sha256", "result_key", "canonical_json", "SessionStore", "TraceFiles", "study_lock"]

SCHEMA = "psmat-study-session/1"
_TMP_PREFIX = ".tmp-"


def file_sha256(path: str | os.PathLike[str] | None) -> str | None:
    """SHA-256 of a file's bytes (hex), None for no file."""
    if path is None:
        return None
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def canonical_json(obj: Any) -> str:
    """One spelling of a JSON value: sorted keys, no spaces, no NaN (ValueError if it is not JSON)."""
    try:
        return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"not representable as JSON: {exc}") from None


def result_key(inputs: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the canonical JSON of a session's inputs (see the module docstring)."""
    return hashlib.sha256(canonical_json({"schema": SCHEMA, **inputs}).encode()).hexdigest()


def _plain(value: Any) -> Any:
    """A row value as JSON: NaN → null, NumPy scalars → Python numbers."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return None if math.isnan(value) else float(value)
    return value


def _unplain(column: str, value: Any) -> Any:
    return math.nan if value is None and column not in ("subject", "trial", "variant", "status") else value


def normalise_rows(rows: Rows) -> Rows:
    """Rows exactly as they come back from disk (JSON numbers, NaN for null), columns in order."""
    return [{c: _unplain(c, _plain(r[c])) for c in COLUMNS} for r in rows]


@contextlib.contextmanager
def _atomic(path: Path, mode: str) -> Iterator[IO[Any]]:
    """Write ``path`` through a hidden temporary file in its folder, fsync, then os.replace."""
    fd, tmp = tempfile.mkstemp(prefix=_TMP_PREFIX + path.name + ".", dir=path.parent)
    try:
        if hasattr(os, "fchmod"):
            os.fchmod(fd, 0o644)  # results are for everyone to read (mkstemp makes them private)
        with os.fdopen(fd, mode, **({"encoding": "utf-8", "newline": ""} if "b" not in mode else {})) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_text_atomic(path: Path, text: str) -> None:
    """``path`` gets ``text`` whole or keeps what it had (temporary file + os.replace)."""
    with _atomic(path, "w") as fh:
        fh.write(text)


@dataclass(frozen=True)
class Stored:
    """One session's result read back: its rows and its traces file (None without traces)."""

    rows: Rows
    traces: Path | None


class SessionStore:
    """The ``results/sessions`` folder of a study (see the module docstring)."""

    def __init__(self, folder: str | os.PathLike[str]) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)

    def path(self, stem: str) -> Path:
        return self.folder / f"{stem}.json"

    def load(self, stem: str, key: str) -> Stored | None:
        """The stored result of ``stem`` if it was made from inputs with ``key``; else None."""
        p = self.path(stem)
        try:
            doc = json.loads(p.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not isinstance(doc, dict) or doc.get("key") != key or not isinstance(doc.get("rows"), list):
            return None
        traces = None if doc.get("traces") is None else self.folder / str(doc["traces"])
        if traces is not None and not traces.is_file():
            return None
        try:
            rows = [{c: _unplain(c, r[c]) for c in COLUMNS} for r in doc["rows"]]
        except (KeyError, TypeError):
            return None
        return Stored(rows, traces)

    def save(self, stem: str, key: str, inputs: Mapping[str, Any], rows: Rows, traces: Traces) -> Stored:
        """Write one session's result (traces first, then the JSON naming them) and drop older traces."""
        name = f"{stem}.{key[:16]}.npz" if traces else None
        if name is not None:
            with _atomic(self.folder / name, "wb") as fh:
                np.savez(fh, **{k: np.asarray(v, np.float64) for k, v in traces.items()})
        plain = [{c: _plain(r[c]) for c in COLUMNS} for r in rows]
        doc = {"key": key, "inputs": dict(inputs), "rows": plain, "traces": name}
        write_text_atomic(self.path(stem), json.dumps(doc, indent=1, allow_nan=False) + "\n")
        own = re.compile(re.escape(stem) + r"\.[0-9a-f]{16}\.npz")
        for old in self.folder.glob(f"{glob_escape(stem)}.*.npz"):
            if own.fullmatch(old.name) and old.name != name:
                old.unlink(missing_ok=True)  # the traces of a result this one replaces
        return Stored(normalise_rows(rows), None if name is None else self.folder / name)

    def stems(self) -> list[str]:
        """Stems of the sessions that have a stored result."""
        return sorted(p.name[: -len(".json")] for p in self.folder.glob("*.json") if not p.name.startswith("."))

    def remove_temporaries(self) -> int:
        """Delete temporary files a killed run left (call only while holding :func:`study_lock`)."""
        n = 0
        for p in self.folder.glob(_TMP_PREFIX + "*"):
            p.unlink(missing_ok=True)
            n += 1
        return n


def glob_escape(text: str) -> str:
    """``text`` with glob's special characters taken literally."""
    return re.sub(r"([*?\[])", r"[\1]", text)


class TraceFiles(Mapping[tuple[str, str], Traces]):
    """{(subject, trial): traces} read from the ``.npz`` files on access, so a large study's
    traces are never all in memory at once."""

    def __init__(self, files: Mapping[tuple[str, str], Path]) -> None:
        self._files = dict(files)

    def __getitem__(self, key: tuple[str, str]) -> Traces:
        with np.load(self._files[key]) as z:
            return {k: z[k] for k in z.files}

    def path(self, key: tuple[str, str]) -> Path:
        """The ``.npz`` file of ``key``."""
        return self._files[key]

    def __iter__(self) -> Iterator[tuple[str, str]]:
        return iter(self._files)

    def __len__(self) -> int:
        return len(self._files)


@contextlib.contextmanager
def study_lock(results: Path) -> Iterator[None]:
    """One run at a time per study: an exclusive lock on ``results/.lock``
    (:func:`psmat._filelock.exclusive_lock`: ``flock`` on POSIX, ``msvcrt.locking`` on
    Windows), released by the system even when the run is killed, so a killed run's lock
    file never blocks the next one.

    Raises
    ------
    RuntimeError
        Another run holds the lock.
    """
    results.mkdir(parents=True, exist_ok=True)
    with contextlib.ExitStack() as held:
        try:
            held.enter_context(exclusive_lock(results / ".lock"))
        except LockHeld:
            raise RuntimeError(f"another psmat study run is writing {results}") from None
        yield
