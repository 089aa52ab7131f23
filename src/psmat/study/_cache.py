"""Per-session results of a study run on disk (docs/spec.md §12): keyed by content, proven when read,
written atomically.

``DIR/results/sessions/<stem>.json`` holds one session's rows and the inputs they were made
from; its traces (:func:`psmat.study.process_trial` with ``traces=True``) are
``<stem>.<key16>.npz`` beside it, with the session's statistics for the work after the sessions
(arrays named ``stats:<name>``, :func:`psmat.study.session_stats`; :class:`TraceFiles` keeps
them apart from the traces). Both are plain files (JSON, NumPy ``.npz``) that any tool
reads. A result is reused only when its stored key equals the key of the current inputs:

``key = sha256(canonical JSON of {schema, psmat version, the whole parameter dict, the stem,
subject, trial, body weight, sha256 of the session file (and of its journal if one lies
beside it), of the platform file, of the study's calibration file if one is used})``

so a changed session, platform file, weight, calibration or parameter reruns exactly the
sessions it touches.

**Each entry proves itself.** The JSON holds ``schema``, ``key``, ``inputs``, ``rows``,
``traces`` (the file name or null), ``traces_sha256`` (SHA-256 of that file's bytes) and

``digest = sha256(len(c) as 8 bytes, big-endian || c)``, ``c`` the canonical JSON (sorted keys,
no spaces, UTF-8) of every other field,

so the digest covers the rows, the key, the inputs and, through ``traces_sha256``, every byte
of the traces file. An entry whose stored key differs from the current key is stale and is
recomputed quietly. An entry with the current key is used only if it parses, has exactly
these fields, its digest and its inputs' key match, its rows are those of the session
(``check_rows`` of ``_plain.py``: one per variant asked for, never none), its traces file
is the one name it may have (``<stem>.<key16>.npz``, in this folder once links are resolved:
no entry can lead a run outside ``results/sessions``) and that file's bytes match
``traces_sha256``. Anything else is recomputed, never trusted and never fatal, and
:meth:`SessionStore.load` says why (the run lists it among its problems). The digest detects
corruption and edits; it is not a signature — whoever can write ``results/`` can also write
``metrics.csv``.

Each file is written to a hidden temporary name, flushed to disk and moved into place with
:func:`os.replace` (:func:`psmat._atomic.open_atomic`): a killed run leaves either the old result or the
new one, never half of one (the traces are moved first, the JSON that names them last).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._atomic import open_atomic, remove_temporaries, write_text_atomic
from .._filelock import LockHeld, exclusive_lock
from ._plain import STATS_PREFIX, TEXT_COLUMNS, Expect, check_rows, digest, first_line, parse_json, plain_rows
from ._trial import Rows, Traces

__all__ = ["SCHEMA", "file_sha256", "result_key", "canonical_json", "entry_digest", "SessionStore", "Stored",
           "Lookup", "TraceFiles", "study_lock", "normalise_rows", "write_text_atomic"]

# 3: rows per condition (column condition); 4: stats:* arrays in the traces; 5: the chain's IECM to a residual
# of 1e-6 (psmat.process.IECM_RTOL), where it was 1e-10: every result of schema 4 is computed again
SCHEMA = "psmat-study-session/5"
#: the fields of an entry (see the module docstring)
FIELDS = frozenset({"schema", "key", "inputs", "rows", "traces", "traces_sha256", "digest"})


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


def normalise_rows(rows: Rows) -> Rows:
    """Rows exactly as they come back from disk (JSON numbers, NaN for null), columns in order."""
    return [{c: (float("nan") if v is None and c not in TEXT_COLUMNS else v) for c, v in r.items()}
            for r in plain_rows(rows)]


def entry_digest(doc: Mapping[str, Any]) -> str:
    """The digest of an entry: of the canonical JSON of every field but ``digest`` (module docstring)."""
    return digest(canonical_json({k: v for k, v in doc.items() if k != "digest"}))


class _Stale(Exception):
    """The entry was made from other inputs: recompute, nothing to report."""


@dataclass(frozen=True)
class Stored:
    """One session's result read back: its rows and its traces file (None without traces)."""

    rows: Rows
    traces: Path | None


@dataclass(frozen=True)
class Lookup:
    """What :meth:`SessionStore.load` found: a result proven to be that of the current inputs,
    or none; ``problem`` says why an entry on disk was not trusted (None when there was no
    entry or it was made from other inputs)."""

    stored: Stored | None
    problem: str | None = None


class SessionStore:
    """The ``results/sessions`` folder of a study (see the module docstring)."""

    def __init__(self, folder: str | os.PathLike[str]) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)

    def path(self, stem: str) -> Path:
        return self.folder / f"{stem}.json"

    @staticmethod
    def traces_name(stem: str, key: str) -> str:
        """The one name the traces file of ``stem`` made from inputs with ``key`` may have."""
        return f"{stem}.{key[:16]}.npz"

    def _inside(self, path: Path) -> Path:
        """``path`` with links resolved, or ValueError if that leaves this folder."""
        real = path.resolve()
        if not real.is_relative_to(self.folder.resolve()):
            raise ValueError(f"{path.name} leads outside {self.folder} (to {real}); not read")
        return real

    def load(self, stem: str, key: str, expect: Expect) -> Lookup:
        """The stored result of ``stem`` if it is proven to be that of inputs with ``key`` (see
        the module docstring); never raises for what is on disk."""
        p = self.path(stem)
        if not p.exists() and not p.is_symlink():
            return Lookup(None)
        try:
            return Lookup(self._verified(p, stem, key, expect))
        except _Stale:
            return Lookup(None)
        except Exception as exc:  # noqa: BLE001 - whatever is wrong on disk, the session is recomputed
            what = str(exc) if isinstance(exc, ValueError) else f"{type(exc).__name__}: {exc}"
            return Lookup(None, f"stored result {p.name} not used ({first_line(what)}); recomputed")

    def _verified(self, p: Path, stem: str, key: str, expect: Expect) -> Stored:
        """The entry at ``p``, every check of the module docstring passed; _Stale, ValueError or OSError."""
        doc = parse_json(self._inside(p).read_bytes())
        if not isinstance(doc, dict):
            raise ValueError("not a JSON object")
        if doc.get("key") != key:
            raise _Stale
        if set(doc) != FIELDS or doc["schema"] != SCHEMA:
            raise ValueError(f"not a {SCHEMA} entry (fields {sorted(doc)})")
        if doc["digest"] != entry_digest(doc):
            raise ValueError("digest mismatch: its rows, inputs or traces entry changed after it was written")
        if not isinstance(doc["inputs"], dict) or result_key(doc["inputs"]) != key:
            raise ValueError("its inputs do not give its key")
        rows = check_rows(doc["rows"], expect)
        name, sha = doc["traces"], doc["traces_sha256"]
        if name is None:
            if sha is not None:
                raise ValueError("a traces digest without a traces file")
            return Stored(rows, None)
        want = self.traces_name(stem, key)
        if name != want:
            raise ValueError(f"it names the traces file {first_line(repr(name), 80)}, not {want} in its folder")
        traces = self._inside(self.folder / want)
        if not traces.is_file():
            raise ValueError(f"its traces file {want} is missing")
        if file_sha256(traces) != sha:
            raise ValueError(f"its traces file {want} changed after it was written (SHA-256 mismatch)")
        return Stored(rows, self.folder / want)

    def save(self, stem: str, key: str, inputs: Mapping[str, Any], rows: Rows, traces: Traces) -> Stored:
        """Write one session's result (traces first, then the JSON naming them) and drop older traces."""
        name = self.traces_name(stem, key) if traces else None
        sha = None
        if name is not None:
            buf = io.BytesIO()
            np.savez(buf, **{k: np.asarray(v, np.float64) for k, v in traces.items()})
            data = buf.getvalue()
            with open_atomic(self.folder / name, "wb") as fh:
                fh.write(data)
            sha = hashlib.sha256(data).hexdigest()
        doc: dict[str, Any] = {"schema": SCHEMA, "key": key, "inputs": dict(inputs), "rows": plain_rows(rows),
                               "traces": name, "traces_sha256": sha}
        doc["digest"] = entry_digest(doc)
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
        return remove_temporaries(self.folder)


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
            return {k: z[k] for k in z.files if not k.startswith(STATS_PREFIX)}

    def stats(self, key: tuple[str, str]) -> dict[str, np.ndarray]:
        """The session's ``stats:<name>`` arrays stored with its traces, as ``{name: array}``."""
        with np.load(self._files[key]) as z:
            return {k[len(STATS_PREFIX):]: z[k] for k in z.files if k.startswith(STATS_PREFIX)}

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
