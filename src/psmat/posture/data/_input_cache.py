"""The posture input cache: one session's :class:`~psmat.posture.data.Recording` in
``DIR/results/posture/inputs/<stem>.npz``, proven when read (as :mod:`psmat.study` (``_cache.py``)).

The file holds the arrays ``t_s`` (float64, (T,)), ``image`` (float32, (T, R, C)) and
``angles_rad`` (float64, (T, 5)), the text ``key`` (of the session's inputs), ``info`` (JSON:
subject, day, meta) and ``digest``:

``digest = sha256 over length-prefixed parts (each as 8 bytes big-endian length, then the
bytes): key, info, then for t_s, image, angles_rad in that order: the name, the dtype
(e.g. "<f8"), the shape as JSON, the C-ordered bytes``.

A file whose key differs from the current key is stale and recomputed quietly. A file with
the current key is used only if it opens (NumPy, ``allow_pickle=False``), holds exactly these
entries with these dtypes and shapes, its digest matches and it lies inside ``DIR/results``
once links are resolved; anything else is recomputed, never trusted and never fatal, and
:func:`read_cached` says why. The digest detects corruption and edits, not a forger.
"""

from __future__ import annotations

import io
import json
import os
from pathlib import Path

import numpy as np

from ..._atomic import open_atomic
from ...study import StaleEntry, digest, first_line, npz_text, parse_json
from ._recording import Recording

__all__ = ["read_cached", "write_cached", "cache_digest"]

_ARRAYS = {"t_s": (np.dtype("<f8"), 1), "image": (np.dtype("<f4"), 3), "angles_rad": (np.dtype("<f8"), 2)}
_ENTRIES = frozenset({"key", "info", "digest", *_ARRAYS})


def cache_digest(key: str, info: str, arrays: dict[str, np.ndarray]) -> str:
    """The digest of a cache file's content (see the module docstring)."""
    parts: list[str | bytes] = [key, info]
    for name in _ARRAYS:
        a = np.ascontiguousarray(arrays[name])
        parts += [name, a.dtype.str, json.dumps(list(a.shape)), a.tobytes()]
    return digest(*parts)


def write_cached(path: Path, key: str, rec: Recording) -> None:
    """Write ``rec`` with ``key`` and its digest to ``path`` (whole or not at all)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    info = json.dumps({"subject": rec.subject, "day": rec.day, "meta": rec.meta}, allow_nan=False)
    arrays = {"t_s": np.asarray(rec.t_s, "<f8"), "image": np.asarray(rec.image, "<f4"),
              "angles_rad": np.asarray(rec.angles_rad, "<f8")}
    buf = io.BytesIO()
    np.savez(buf, key=np.array(key), info=np.array(info), digest=np.array(cache_digest(key, info, arrays)),
             **arrays)
    with open_atomic(path, "wb") as fh:
        fh.write(buf.getvalue())


def _verified(path: Path, key: str, results: Path) -> Recording:
    real = path.resolve()
    if not real.is_relative_to(results.resolve()):
        raise ValueError(f"it leads outside {results} (to {real}); not read")
    with open(real, "rb") as fh, np.load(fh, allow_pickle=False) as z:  # our handle: closed even on a bad zip
        arrays = {k: z[k] for k in z.files}
    if "key" not in arrays or npz_text(arrays, "key") != key:
        raise StaleEntry
    if set(arrays) != _ENTRIES:
        raise ValueError(f"entries {sorted(arrays)}, expected {sorted(_ENTRIES)}")
    for name, (dtype, ndim) in _ARRAYS.items():
        if arrays[name].dtype != dtype or arrays[name].ndim != ndim:
            raise ValueError(f"{name} is {arrays[name].dtype} with {arrays[name].ndim} dimension(s), "
                             f"expected {dtype} with {ndim}")
    info = npz_text(arrays, "info")
    if npz_text(arrays, "digest") != cache_digest(key, info, arrays):
        raise ValueError("digest mismatch: the file changed after it was written")
    doc = parse_json(info)
    if not (isinstance(doc, dict) and isinstance(doc.get("subject"), str) and type(doc.get("day")) is int
            and isinstance(doc.get("meta"), dict)):
        raise ValueError("info is not {subject, day, meta}")
    return Recording(subject=doc["subject"], day=doc["day"], t_s=arrays["t_s"], image=arrays["image"],
                     angles_rad=arrays["angles_rad"], meta=doc["meta"])


def read_cached(path: str | os.PathLike[str], key: str, results: str | os.PathLike[str]
                ) -> tuple[Recording | None, str | None]:
    """(the cached recording, None) if ``path`` is proven to hold that of inputs with ``key``;
    else (None, why it was not used) — why is None when there is no file or it is stale.

    Parameters
    ----------
    path : path
        The cache file.
    key : str
        The key of the session's current inputs.
    results : path
        ``DIR/results``: the cache file must lie inside it once links are resolved.
    """
    path = Path(path)
    if not os.path.lexists(path):
        return None, None
    try:
        return _verified(path, key, Path(results)), None
    except StaleEntry:
        return None, None
    except Exception as exc:  # noqa: BLE001 - zip, format, JSON, shape: whatever is wrong, recompute
        what = str(exc) if isinstance(exc, ValueError) else f"{type(exc).__name__}: {exc}"
        return None, f"cached inputs {path.name} not used ({first_line(what)}); recomputed"
