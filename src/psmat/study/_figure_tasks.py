"""A study's figures as independent tasks (docs/spec.md §12): one task per figure, run in the
same worker pool as the sessions, each keyed by the digest of what it draws.

A :class:`FigureTask` holds plain values only — the summary rows, the whole-trial rows, or the
one session's traces a CoP figure draws — so it travels to any worker by pickle, and
:func:`draw_figure` returns the PNG's bytes (matplotlib's Agg, no pyplot state): the bytes are a
function of the task alone, so they are the same whatever process, or how many, drew them.

**Incremental.** A task's ``key`` is the SHA-256 of its kind, its values (rows as JSON with
floats spelled exactly, arrays by their bytes), the label and the psmat and matplotlib versions.
``results/figures/.keys.json`` (:class:`FigureIndex`) records, per figure, the key it was drawn
from and its file's SHA-256: a figure whose key and bytes are those recorded is not drawn
again nor rewritten (its mtime stays), so a rerun after one session changed redraws only the
figures that draw that session (the bars and Bland–Altman plots, which draw every volunteer;
a CoP figure only when it draws that session or its median session changed).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._atomic import write_text_atomic
from ._cache import file_sha256
from ._summary import REFERENCE, StudyRows

__all__ = ["FigureTask", "figure_tasks", "most_work_first", "draw_figure", "FigureIndex"]

_SCHEMA = "psmat-study-figures/1"  # the format of results/figures/.keys.json
KEYS_FILE = ".keys.json"


@dataclass(frozen=True)
class FigureTask:
    """One figure: its name (``sigma_bars``, ``cop_traces_<trial>``, ...), the file it goes to,
    what draws it (``kind``) from which plain values (``args``), and their ``key``."""

    name: str
    path: str
    kind: str
    args: tuple[Any, ...]
    key: str


def _plain(x: Any) -> Any:
    """A JSON-able spelling of ``x`` for the key: arrays by dtype, shape and SHA-256 of their bytes."""
    if isinstance(x, np.ndarray):
        a = np.ascontiguousarray(x)
        return {"dtype": a.dtype.str, "shape": list(a.shape), "sha256": hashlib.sha256(a.tobytes()).hexdigest()}
    if isinstance(x, Mapping):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, float):
        return repr(float(x))  # exact, NaN and infinities included
    if isinstance(x, (np.integer, np.floating)):
        return _plain(x.item())
    return x


def _key(kind: str, args: tuple[Any, ...], versions: tuple[str, str]) -> str:
    doc = {"schema": _SCHEMA, "kind": kind, "args": _plain(args), "psmat": versions[0], "matplotlib": versions[1]}
    return hashlib.sha256(json.dumps(doc, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def _slug(name: str) -> str:
    """A file-name-safe form of a trial name."""
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)


def figure_tasks(figures_dir: Path, study_rows: Sequence[Mapping[str, Any]], study: StudyRows,
                 summary: Sequence[Mapping[str, Any]], traces: Mapping[tuple[str, str], Mapping[str, Any]],
                 label: str | None, version: str) -> list[FigureTask]:
    """The study's figures as tasks, in the order of the report.

    Parameters
    ----------
    figures_dir : Path
        ``results/figures``.
    study_rows : sequence of mapping
        The whole-trial rows (``study`` indexes them).
    study : StudyRows
        :func:`psmat.study.index_rows` of ``study_rows``.
    summary : sequence of mapping
        :func:`psmat.study.summary_rows` of ``study``.
    traces : mapping
        ``(subject, trial) -> traces``; only the median session of each trial is read.
    label : str or None
        Shown in the titles.
    version : str
        The psmat version (part of every key).
    """
    import matplotlib

    from . import _figures as fig

    versions = (version, matplotlib.__version__)
    out: list[FigureTask] = []

    def add(name: str, kind: str, *args: Any) -> None:
        out.append(FigureTask(name, str(figures_dir / f"{name}.png"), kind, args, _key(kind, args, versions)))

    if not study.trials:
        return out
    summary = [dict(r) for r in summary]
    add("sigma_bars", "sigma_bars", summary, label)
    add("eu_bars", "eu_bars", summary, label)
    drawn, rank = fig.trace_variants(study), fig.ranking_variant(study)
    for trial in study.trials:
        subject = fig.median_session(study, trial, traces)
        if subject is None:
            continue
        tr = traces[(subject, trial)]
        used = {k: np.asarray(tr[k]) for k in ("t_s", REFERENCE, *drawn) if k in tr}
        add(f"cop_traces_{_slug(trial)}", "cop_traces", used, subject, trial, tuple(drawn), rank,
            tuple(study.variants), label)
    rows = [dict(r) for r in study_rows]
    for metric, name in (("sd_ml_cm", "bland_altman_ml"), ("sd_ap_cm", "bland_altman_ap")):
        add(name, "bland_altman", rows, summary, metric, label)
    return out


#: The figure kinds by the work one takes, most first: a thesis-size study's figures on the 2-core
#: machine (warm process): a Bland–Altman plot (27 panels) 1.0 s, the σ bars 0.7 s, the Eu bars
#: 0.36 s, a trial's CoP traces 0.2 s.
_WORK_ORDER = ("bland_altman", "sigma_bars", "eu_bars", "cop_traces")


def most_work_first(tasks: Sequence[FigureTask]) -> list[FigureTask]:
    """``tasks`` in the order they are handed to the workers: the kinds that take longest first
    (:data:`_WORK_ORDER`; otherwise as given), so that fewer workers than figures do not end the
    stage on a Bland–Altman plot begun last (the rule of the sessions' order, :mod:`psmat.study`
    (``_order.py``)). The bytes of a figure do not depend on it."""
    rank = {kind: i for i, kind in enumerate(_WORK_ORDER)}
    return sorted(tasks, key=lambda t: rank.get(t.kind, len(rank)))


def draw_figure(task: FigureTask) -> tuple[str, bytes]:
    """Draw one figure (in whichever process runs it): (its name, the PNG's bytes)."""
    from . import _figures as fig
    from ._summary import index_rows

    buf = io.BytesIO()
    if task.kind == "sigma_bars":
        fig.sigma_bars(task.args[0], buf, task.args[1])
    elif task.kind == "eu_bars":
        fig.eu_bars(task.args[0], buf, task.args[1])
    elif task.kind == "cop_traces":
        fig.draw_cop_traces(*task.args[:6], buf, task.args[6])
    elif task.kind == "bland_altman":
        rows, summary, metric, label = task.args
        fig.bland_altman_plot(index_rows(rows), summary, metric, buf, label)
    else:
        raise ValueError(f"unknown figure kind {task.kind!r}")
    return task.name, buf.getvalue()


class FigureIndex:
    """``results/figures/.keys.json``: per figure, the key it was drawn from and its file's SHA-256."""

    def __init__(self, folder: Path) -> None:
        self.path = folder / KEYS_FILE
        self._entries: dict[str, dict[str, str]] = {}
        with contextlib.suppress(OSError, ValueError, TypeError, AttributeError):
            doc = json.loads(self.path.read_text(encoding="utf-8"))
            if isinstance(doc, dict) and doc.get("schema") == _SCHEMA and isinstance(doc.get("figures"), dict):
                self._entries = {str(k): dict(v) for k, v in doc["figures"].items() if isinstance(v, dict)}

    def current(self, task: FigureTask) -> bool:
        """Whether ``task``'s file holds the figure of its key (the bytes recorded for it)."""
        entry = self._entries.get(task.name)
        if entry is None or entry.get("key") != task.key:
            return False
        try:
            return file_sha256(Path(task.path)) == entry.get("sha256")
        except OSError:
            return False

    def record(self, task: FigureTask, data: bytes) -> None:
        """``task``'s figure is ``data`` (written by the caller)."""
        self._entries[task.name] = {"key": task.key, "sha256": hashlib.sha256(data).hexdigest()}

    def save(self) -> None:
        """Write the index atomically."""
        write_text_atomic(self.path, json.dumps({"schema": _SCHEMA, "figures": self._entries}, indent=1,
                                                sort_keys=True) + "\n")
