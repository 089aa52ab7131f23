"""A session's result as plain data, checked: rows as JSON values, traces as float64 arrays.

Used wherever a result crosses a line of trust: read back from ``results/sessions``
(:mod:`psmat.study` (``_cache.py``)) and received from a Dask worker (:mod:`psmat.study` (``_cluster.py``)). Nothing
here unpickles: JSON (NaN and infinities refused), NumPy ``.npz`` read with
``allow_pickle=False``. Every check raises :class:`ValueError` with one line saying what failed.

* :func:`check_rows`: a session's rows are one per variant, ``FP`` first then the variants asked
  for, in that order, of the session's subject and trial, for the whole trial (``condition`` "")
  and then the same for each of its conditions (a label each, none twice), text where
  :data:`COLUMNS` holds text and numbers (or null) elsewhere;
* :func:`check_row`: one row's columns and their types (text or a finite number or null);
* :func:`check_traces`: ``t_s`` of shape (N,), each other trace (N, 2), float64,
  named after FP or a variant asked for; arrays named ``stats:<name>`` (:data:`STATS_PREFIX`) are
  a session's statistics for the study-level work after the sessions (float64, at most 3-D);
* :func:`encode_result` / :func:`decode_result`: (stem, rows, traces) as one ``.npz`` byte
  string (the rows as UTF-8 JSON in the array ``__result__``);
* :func:`stamp` / :func:`check_timed`: a task's result and its time in the worker
  (:class:`psmat.study._timings.TaskTime`) as the pair ``(result, {start, wall_s, cpu_s, pid,
  worker})`` of plain numbers and text that a Dask worker sends back, and its check.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._timings import TaskTime
from ._trial import COLUMNS, Rows, Traces

#: the prefix of the arrays stored with a session's traces that are no trace: statistics the work
#: after the sessions needs from that session alone (:func:`psmat.study.session_stats`)
STATS_PREFIX = "stats:"

__all__ = ["STATS_PREFIX", "Expect", "TEXT_COLUMNS", "parse_json", "plain_rows", "check_row", "check_rows",
           "check_traces", "digest", "read_result", "encode_plain", "encode_result",
           "decode_result", "first_line", "stamp", "check_timed"]

#: the columns that hold text; every other column holds a number or nothing (null / NaN)
TEXT_COLUMNS = frozenset({"subject", "trial", "variant", "condition", "ispgr", "status"})
_RESULT = "__result__"
_BASE = frozenset(COLUMNS)


@dataclass(frozen=True)
class Expect:
    """What a session's result must be: its stem, subject, trial and the variants asked for."""

    stem: str
    subject: str
    trial: str
    variants: tuple[str, ...]
    #: the rows' columns: :data:`COLUMNS`, then the descriptors' when the run asked for them
    columns: tuple[str, ...] = COLUMNS


def _no_constant(name: str) -> Any:
    raise ValueError(f"JSON holds {name}, which is not JSON")


def parse_json(text: str | bytes) -> Any:
    """JSON text → value; NaN, Infinity and -Infinity refused (ValueError, also for deep nesting)."""
    try:
        return json.loads(text, parse_constant=_no_constant)
    except RecursionError:
        raise ValueError("JSON nested too deeply") from None


def _plain(value: Any) -> Any:
    """A row value as JSON: NaN → null, NumPy scalars → Python numbers."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return None if math.isnan(value) else float(value)
    return value


def plain_rows(rows: Rows) -> list[dict[str, Any]]:
    """Rows as JSON values, columns in :data:`COLUMNS` order then any further ones (the
    descriptors) in the row's order (NaN → null)."""
    return [{c: _plain(r[c]) for c in (*COLUMNS, *(k for k in r if k not in _BASE))} for r in rows]


def check_rows(value: Any, expect: Expect) -> Rows:
    """Rows read as JSON (:func:`plain_rows`' form) → rows (null → NaN), or ValueError.

    Raises
    ------
    ValueError
        Not a non-empty list of objects with exactly the columns ``expect.columns``; a text
        column not text or a number column not a number (booleans and non-finite numbers
        refused); another subject or trial; variants other than ``FP`` then ``expect.variants``
        for the whole trial (first) and for each condition after it (one label per group of
        rows, no label twice).
    """
    if not isinstance(value, list) or not value:
        raise ValueError("no rows (a session has one row per variant)")
    out: Rows = [check_row(r, expect.columns, k) for k, r in enumerate(value)]
    if any((r["subject"], r["trial"]) != (expect.subject, expect.trial) for r in out):
        raise ValueError(f"rows of another session (expected subject {expect.subject!r}, trial {expect.trial!r})")
    n = len(expect.variants) + 1
    groups = [out[i:i + n] for i in range(0, len(out), n)]
    labels = []
    for group in groups:
        variants = [r["variant"] for r in group]
        if variants != ["FP", *expect.variants]:
            raise ValueError(f"rows for variants {variants}, expected {['FP', *expect.variants]}")
        label = group[0]["condition"]
        if any(r["condition"] != label for r in group) or (label == "") != (not labels) or label in labels:
            raise ValueError("the whole trial's rows (condition \"\") first, then one group of rows per condition, "
                             "each label once")
        labels.append(label)
    return out


def check_row(value: Any, columns: tuple[str, ...], k: int = 0) -> dict[str, Any]:
    """One row read as JSON → the row (null → NaN, columns in the order of ``columns``).

    Raises
    ------
    ValueError
        Not an object with exactly ``columns``; a text column (:data:`TEXT_COLUMNS`) not text or
        another column not a finite number or null (booleans refused); ``k`` numbers the row in
        the message.
    """
    if not isinstance(value, dict) or set(value) != set(columns):
        raise ValueError(f"row {k} does not have exactly the columns of metrics.csv")
    row: dict[str, Any] = {}
    for c in columns:
        v = value[c]
        if c in TEXT_COLUMNS:
            if not isinstance(v, str):
                raise ValueError(f"row {k}: {c} is not text")
            row[c] = v
        elif v is None:
            row[c] = math.nan
        elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"row {k}: {c} is not a finite number or null")
        else:
            row[c] = v
    return row


def check_traces(traces: Mapping[str, Any], expect: Expect) -> Traces:
    """Traces → ``{name: float64 array}`` or ValueError (see the module docstring)."""
    allowed = {"t_s", "FP", *expect.variants}
    unknown = sorted(n for n in set(traces) - allowed if not n.startswith(STATS_PREFIX))
    if unknown:
        raise ValueError(f"traces named {unknown}, not FP or a variant asked for")
    out: Traces = {}
    n = None
    for name, arr in traces.items():
        a = np.asarray(arr)
        if a.dtype != np.float64:
            raise ValueError(f"trace {name}: dtype {a.dtype}, expected float64")
        if name.startswith(STATS_PREFIX):
            if a.ndim > 3:
                raise ValueError(f"statistics {name}: shape {a.shape}, expected at most 3 dimensions")
            out[name] = a
            continue
        shape = (a.shape[0],) if name == "t_s" else (a.shape[0], 2)
        if a.ndim == 0 or a.shape != shape or (n is not None and a.shape[0] != n):
            raise ValueError(f"trace {name}: shape {a.shape}, expected (N,) for t_s and (N, 2) for a CoP trace")
        n = a.shape[0]
        out[name] = a
    if out and "t_s" not in out:
        raise ValueError("traces without t_s")
    return out


class StaleEntry(Exception):
    """A stored entry made from other inputs than the current ones: recomputed, nothing to report
    (the caches of psmat.study and psmat.posture)."""


def npz_text(arrays: Mapping[str, np.ndarray], name: str) -> str:
    """The text entry ``name`` of a stored ``.npz`` (a 0-d unicode array).

    Raises
    ------
    ValueError
        It is not one.
    """
    a = arrays[name]
    if a.ndim != 0 or a.dtype.kind != "U":
        raise ValueError(f"{name} is not text")
    return str(a)


def digest(*parts: str | bytes) -> str:
    """SHA-256 (hex) of ``parts``, each length-prefixed so that no two sequences collide."""
    h = hashlib.sha256()
    for p in parts:
        b = p.encode() if isinstance(p, str) else bytes(p)
        h.update(len(b).to_bytes(8, "big"))
        h.update(b)
    return h.hexdigest()


def encode_result(stem: str, rows: Rows, traces: Mapping[str, Any]) -> bytes:
    """(stem, rows, traces) → ``.npz`` bytes: no pickle inside, so any side reads it as data."""
    return encode_plain({"stem": stem, "rows": plain_rows(rows)}, traces)


def read_result(data: Any) -> tuple[Any, dict[str, np.ndarray]]:
    """Bytes of an ``.npz`` written like :func:`encode_result`'s → (its JSON document, its other
    arrays), read without pickle; the caller checks both.

    Raises
    ------
    ValueError
        Not bytes, not an ``.npz``, an array that needs pickle, no ``__result__`` array of bytes,
        or not JSON (NaN and infinities refused) in it.
    """
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise ValueError(f"a result must be bytes, got {type(data).__name__}")
    try:
        with np.load(io.BytesIO(bytes(data)), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except Exception as exc:  # noqa: BLE001 - zipfile, format and pickle errors alike: not a result
        raise ValueError(f"not a result file ({type(exc).__name__}: {exc})") from None
    head = arrays.pop(_RESULT, None)
    if head is None or head.dtype != np.uint8 or head.ndim != 1:
        raise ValueError(f"no {_RESULT} in the result")
    try:
        return parse_json(head.tobytes().decode("utf-8")), arrays
    except (ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"result rows: {exc}") from None


def encode_plain(doc: Any, arrays: Mapping[str, Any]) -> bytes:
    """A JSON document and float64 arrays as ``.npz`` bytes (:func:`read_result` reads them back)."""
    head = json.dumps(doc, allow_nan=False).encode()
    buf = io.BytesIO()
    np.savez(buf, **{_RESULT: np.frombuffer(head, np.uint8)},
             **{k: np.asarray(v, np.float64) for k, v in arrays.items()})
    return buf.getvalue()


def decode_result(data: bytes, expect: Expect) -> tuple[str, Rows, Traces]:
    """:func:`encode_result`'s bytes → (stem, rows, traces), checked against ``expect``.

    Raises
    ------
    ValueError
        Not such bytes (not an ``.npz``, an array that needs pickle, bad JSON), another stem,
        or rows or traces that fail :func:`check_rows` / :func:`check_traces`.
    """
    doc, arrays = read_result(data)
    if not isinstance(doc, dict) or set(doc) != {"stem", "rows"}:
        raise ValueError("the result's JSON is not {stem, rows}")
    if doc["stem"] != expect.stem:
        raise ValueError(f"a result for {doc['stem']!r}, expected {expect.stem!r}")
    return expect.stem, check_rows(doc["rows"], expect), check_traces(arrays, expect)


def first_line(text: str, limit: int = 300) -> str:
    """``text`` as one line of at most ``limit`` characters."""
    line = " ".join(str(text).split())
    return line if len(line) <= limit else line[: limit - 1] + "…"


#: the fields of a task's time as a worker sends it (:func:`stamp`)
_TIME_FIELDS = ("start", "wall_s", "cpu_s", "pid", "worker")
#: the longest worker address accepted (characters)
_WORKER_MAX = 256


def stamp(result: Any, took: TaskTime) -> tuple[Any, dict[str, Any]]:
    """``(result, time)``: a task's result and its :class:`TaskTime` as a map of plain numbers
    and text (``start`` s since the epoch, ``wall_s``, ``cpu_s`` s, ``pid``, ``worker``), the
    form a Dask worker sends back (msgpack carries it; :func:`check_timed` reads it)."""
    return result, {"start": float(took.start), "wall_s": float(took.wall_s), "cpu_s": float(took.cpu_s),
                    "pid": int(took.pid), "worker": str(took.worker)}


def check_timed(value: Any) -> tuple[Any, TaskTime]:
    """:func:`stamp`'s pair → (result, :class:`TaskTime`), the time checked (the result is the
    caller's to check).

    Raises
    ------
    ValueError
        Not a pair; a time that is not a map of exactly ``start``, ``wall_s``, ``cpu_s``
        (finite numbers, the two durations >= 0), ``pid`` (an integer >= 0) and ``worker``
        (printable text of at most 256 characters).
    """
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise ValueError("a task's answer must be the pair (result, time)")
    result, t = value
    if not isinstance(t, dict) or set(t) != set(_TIME_FIELDS):
        raise ValueError(f"a task's time must be a map of exactly {', '.join(_TIME_FIELDS)}")
    for name in ("start", "wall_s", "cpu_s"):
        v = t[name]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                or (name != "start" and v < 0):
            raise ValueError(f"a task's {name} is not a finite number" + ("" if name == "start" else " >= 0"))
    pid, worker = t["pid"], t["worker"]
    if isinstance(pid, bool) or not isinstance(pid, int) or pid < 0:
        raise ValueError("a task's pid is not an integer >= 0")
    if not isinstance(worker, str) or len(worker) > _WORKER_MAX or not worker.isprintable():
        raise ValueError(f"a task's worker is not printable text of at most {_WORKER_MAX} characters")
    return result, TaskTime(float(t["start"]), float(t["wall_s"]), float(t["cpu_s"]), pid, worker)
