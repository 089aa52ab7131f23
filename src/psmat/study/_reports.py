"""Per-subject HTML reports of a study (``psmat study run DIR --reports``; docs/spec.md §6, §12).

One page per subject, ``DIR/results/reports/<subject>.html``, made by
:func:`psmat.report.render_report` (the page of :func:`psmat.report.write_report`) from that
subject's closed sessions, each with its
force-platform CSV and its ``events/<stem>.csv`` when the study has them; the title names the
subject, the line under it the body weight and height from ``subjects.csv``.

**Resumable, like the sessions.** A report's key is

``sha256(canonical JSON of {schema, psmat version, the report's parameters, the subject, its
subjects.csv row, and per session (in page order) its stem, label and the sha256 of its session,
journal, platform, events and calibration files})``

(the digests the session keys are made of, :mod:`psmat.study` (``_cache.py``)).
``reports/.keys.json`` holds, per subject, the key and the SHA-256 of the page written from it;
a page whose key and bytes both match is not written again. Each page is written atomically,
by the worker process that made it (:func:`run_report`) or, on a Dask cluster, by the client from
the text the worker sent back and the client checked (:func:`render_page`,
:func:`psmat.report.check_page`); the index after each page, so a killed run loses at most the
pages in flight.
A page that cannot be made is one problem line of the run; its subject's entry is dropped so the
next run tries again, and an older page of that subject stays on disk, unlisted.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .._atomic import remove_temporaries, write_text_atomic
from ._cache import canonical_json, file_sha256
from ._layout import StudyLayout
from ._task import SessionTask

__all__ = ["ReportTask", "run_report", "render_page", "report_tasks", "ReportIndex", "REPORTS_DIR"]

SCHEMA = "psmat-study-report/2"  # 2: the chain's IECM to a residual of 1e-6 (psmat.process.IECM_RTOL)
#: the folder under ``results/`` that holds the pages
REPORTS_DIR = "reports"


@dataclass(frozen=True)
class ReportTask:
    """One subject's page as a task: plain values only (it travels to a worker process by pickle)."""

    subject: str
    out: str
    #: per session: (session, platform or None, label, markers (host s, label) or None: the session's own)
    items: tuple[tuple[str, str | None, str, tuple[tuple[float, str], ...] | None], ...]
    title: str
    line: str
    params: dict[str, Any]
    key: str
    #: a problem of the page that does not stop it (one line), or ""
    note: str = ""


def render_page(task: ReportTask) -> tuple[str | None, str | None]:
    """One subject's page as text (in whichever process runs it), nothing written: (page, None)
    or (None, why not, one line); never raises for a session the report cannot use."""
    from ..report import ReportItem, render_report

    items = [ReportItem(s, p, label, events) for s, p, label, events in task.items]
    try:
        return render_report(items, title=task.title, subject=task.line, params=task.params), None
    except Exception as exc:  # noqa: BLE001 - one subject's failure is a problem line, never a failed study
        why = str(exc) if isinstance(exc, ValueError) else f"{type(exc).__name__}: {exc}"
        return None, " ".join(why.split())


def run_report(task: ReportTask) -> tuple[str, str | None]:
    """Write one subject's page atomically (in whichever process runs it, the study folder at
    hand): (subject, None) or (subject, why not, one line); never raises for a session the
    report cannot use."""
    text, why = render_page(task)
    if text is not None:
        try:
            write_text_atomic(task.out, text)
        except OSError as exc:
            return task.subject, " ".join(f"{type(exc).__name__}: {exc}".split())
    return task.subject, why


def file_name(subject: str) -> str:
    """``<subject>.html``, characters other than letters, digits, ``-``, ``_`` and ``.`` as ``_``."""
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in subject).lstrip(".") or "_"
    return f"{safe}.html"


def _person(layout: StudyLayout, subject: str) -> tuple[str, dict[str, Any] | None]:
    """The line under the title (weight, height) and the subjects.csv row the key holds."""
    who = layout.subjects.get(subject)
    if who is None:
        return f"{subject} (not in subjects.csv)", None
    parts = [subject, f"body weight {who.weight_kg:g} kg"]
    height = who.extra.get("height_cm", "")
    if height:
        parts.append(f"height {height} cm")
    return ", ".join(parts), {"weight_kg": who.weight_kg, **who.extra}


def report_tasks(layout: StudyLayout, tasks: Mapping[str, SessionTask], order: Sequence[str],
                 closed: set[str], version: str) -> list[ReportTask]:
    """One task per subject (its sessions in ``order``, the closed ones only); a subject whose
    sessions use different calibration files gets none and a note saying so."""
    folder = layout.results / REPORTS_DIR
    by_subject: dict[str, list[SessionTask]] = {}
    for stem in order:
        if stem in closed:
            by_subject.setdefault(tasks[stem].subject, []).append(tasks[stem])
    out = []
    for subject, ts in by_subject.items():
        cals = {t.calibration for t in ts}
        note = (f"report of {subject}: its sessions use different calibration files; the report uses none"
                if len(cals) > 1 else "")
        p = ts[0].params
        params = {"preset": p["preprocess"], "method": p["method"], "max_lag_s": p["max_lag_s"],
                  "platform_axes": p["platform_axes"], "calibration": next(iter(cals)) if len(cals) == 1 else None}
        items = tuple((t.session, t.forceplate, f"{t.trial} ({Path(t.session).name})", t.events) for t in ts)
        line, row = _person(layout, subject)
        title = f"{subject}: balance study report"
        inputs = {"schema": SCHEMA, "psmat": version, "params": {**params, "calibration": None},
                  "subject": subject, "row": row, "title": title, "sessions": [
                      {k: t.inputs[k] for k in ("stem", "trial", "session_sha256", "journal_sha256",
                                                "forceplate_sha256", "events_sha256", "calibration_sha256")}
                      | {"label": label} for t, (_, _, label, _) in zip(ts, items)]}
        key = hashlib.sha256(canonical_json(inputs).encode()).hexdigest()
        out.append(ReportTask(subject, str(folder / file_name(subject)), items, title, line, params, key, note))
    return out


class ReportIndex:
    """``results/reports/.keys.json``: per subject, the key and the SHA-256 of its page."""

    def __init__(self, folder: str | os.PathLike[str]) -> None:
        self.folder = Path(folder)
        self.path = self.folder / ".keys.json"
        try:
            doc = json.loads(self.path.read_text(encoding="utf-8"))
            entries = doc["reports"] if isinstance(doc, dict) and doc.get("schema") == SCHEMA else {}
            self.entries: dict[str, dict[str, str]] = {
                str(s): {"key": str(e["key"]), "sha256": str(e["sha256"]), "file": str(e["file"])}
                for s, e in entries.items()}
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            self.entries = {}  # no index, or an unreadable one: every page is written again

    def current(self, task: ReportTask) -> bool:
        """The page of ``task`` on disk was written from the same key and is unchanged since."""
        e = self.entries.get(task.subject)
        out = Path(task.out)
        if e is None or e["key"] != task.key or e["file"] != out.name or not out.is_file():
            return False
        try:
            return file_sha256(out) == e["sha256"]
        except OSError:
            return False

    def record(self, task: ReportTask, ok: bool) -> None:
        """Note the page of ``task`` as written (ok) or failed (its entry dropped), and save the index."""
        if ok:
            self.entries[task.subject] = {"key": task.key, "sha256": file_sha256(task.out) or "",
                                          "file": Path(task.out).name}
        else:
            self.entries.pop(task.subject, None)
        self.folder.mkdir(parents=True, exist_ok=True)
        write_text_atomic(self.path, json.dumps({"schema": SCHEMA, "reports": self.entries}, indent=1,
                                                sort_keys=True) + "\n")

    def remove_temporaries(self) -> int:
        """Delete the temporary files a killed run left in the folder."""
        return remove_temporaries(self.folder)
