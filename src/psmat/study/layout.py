"""A study on disk (docs/spec.md §6): find its sessions, pair each with its force-platform file and
its subject, and say what is missing — without stopping at the first problem.

```
DIR/subjects.csv          subject, weight_kg, height_cm, age, sex, ...
DIR/sessions/*.h5         mat sessions; metadata holds subject and trial
DIR/forceplate/*.csv      force-platform CoP, same stem as the session it belongs to
DIR/calibration/*.json    optional, per box serial number
DIR/results/              written by ``psmat study run``
DIR/truth/                simulated studies only; never read here
```
"""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["Subject", "StudyItem", "StudyLayout", "read_subjects", "find_study"]


@dataclass(frozen=True)
class Subject:
    """One row of ``subjects.csv``: the id, the body weight and whatever else it holds."""

    subject: str
    weight_kg: float
    extra: dict[str, str] = field(default_factory=dict)

    @property
    def weight_n(self) -> float:
        """Body weight in N (standard gravity)."""
        return self.weight_kg * 9.80665


@dataclass
class StudyItem:
    """One session of a study and what belongs to it; ``problems`` lists what is missing."""

    stem: str
    session: Path
    forceplate: Path | None
    subject: str | None
    trial: str | None
    problems: list[str] = field(default_factory=list)
    simulated: bool = False  # the session's metadata says a simulator wrote it

    @property
    def ok(self) -> bool:
        return not self.problems


@dataclass
class StudyLayout:
    """The parts of a study folder (see the module docstring)."""

    root: Path
    subjects: dict[str, Subject]
    items: list[StudyItem]
    calibrations: dict[str, Path]
    problems: list[str] = field(default_factory=list)

    @property
    def results(self) -> Path:
        return self.root / "results"

    @property
    def simulated(self) -> bool:
        """Every session says a simulator wrote it (its metadata, not ``truth/``)."""
        return bool(self.items) and all(i.simulated for i in self.items)


def read_subjects(path: str | os.PathLike[str]) -> dict[str, Subject]:
    """``subjects.csv`` → {subject id: Subject}; a missing or bad weight is one clear ValueError."""
    path = Path(path)
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        names = [n.strip() for n in (reader.fieldnames or [])]
        for need in ("subject", "weight_kg"):
            if need not in names:
                raise ValueError(f"{path}: needs a column {need!r}, has {names}")
        out: dict[str, Subject] = {}
        for k, row in enumerate(reader, start=2):
            row = {(a or "").strip(): (b or "").strip() for a, b in row.items()}
            sid = row.pop("subject")
            if not sid:
                raise ValueError(f"{path}:{k}: empty subject id")
            if sid in out:
                raise ValueError(f"{path}:{k}: subject {sid!r} appears twice")
            try:
                w = float(row.pop("weight_kg"))
            except ValueError:
                raise ValueError(f"{path}:{k}: weight_kg of {sid!r} is not a number") from None
            if not 0 < w < 500:
                raise ValueError(f"{path}:{k}: weight_kg of {sid!r} is {w:g}; expected kg in (0, 500)")
            out[sid] = Subject(sid, w, row)
    return out


def _session_meta(path: Path) -> tuple[str | None, str | None, str | None, bool]:
    """(subject, trial, problem, simulated) from a session's metadata (the loader checks the whole file)."""
    from ..io import SessionFormatError, load_session

    try:
        meta = load_session(path).metadata
    except (SessionFormatError, OSError) as exc:
        return None, None, f"unreadable session: {exc}", False
    subject = meta.get("subject")
    trial = meta.get("trial")
    return ((None if subject is None else str(subject)), (None if trial is None else str(trial)), None,
            meta.get("simulated") is True)


def find_study(root: str | os.PathLike[str]) -> StudyLayout:
    """Discover a study folder; problems are collected per session, never raised per session.

    Raises
    ------
    FileNotFoundError
        ``root`` or ``root/sessions`` does not exist.
    """
    root = Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"study folder not found: {root}")
    sessions = root / "sessions"
    if not sessions.is_dir():
        raise FileNotFoundError(f"{root} has no sessions/ folder (docs/spec.md §6 study layout)")
    problems: list[str] = []
    subjects: dict[str, Subject] = {}
    sub_csv = root / "subjects.csv"
    if sub_csv.is_file():
        try:
            subjects = read_subjects(sub_csv)
        except ValueError as exc:
            problems.append(str(exc))
    else:
        problems.append(f"{sub_csv} not found: no body weights")
    plates = {p.stem: p for p in sorted((root / "forceplate").glob("*")) if p.suffix.lower() in (".csv", ".tsv", ".txt")}
    cal = {p.stem: p for p in sorted((root / "calibration").glob("*.json"))}
    items = []
    for s in sorted(sessions.glob("*.h5")):
        subject, trial, problem, simulated = _session_meta(s)
        item = StudyItem(s.stem, s, plates.get(s.stem), subject, trial, simulated=simulated)
        if problem:
            item.problems.append(problem)
        else:
            if subject is None:
                item.problems.append("session metadata has no subject")
            elif subject not in subjects:
                item.problems.append(f"subject {subject!r} is not in subjects.csv")
            if trial is None:
                item.problems.append("session metadata has no trial")
        if item.forceplate is None:
            item.problems.append(f"no force-platform file forceplate/{s.stem}.csv")
        items.append(item)
    if not items:
        problems.append(f"{sessions} holds no *.h5 session")
    return StudyLayout(root, subjects, items, cal, problems)


def describe(layout: StudyLayout) -> dict[str, Any]:
    """Counts for a progress line: sessions, ready, with problems."""
    ready = sum(1 for i in layout.items if i.ok)
    return {"sessions": len(layout.items), "ready": ready, "with_problems": len(layout.items) - ready}
