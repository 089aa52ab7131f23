"""A study on disk (docs/spec.md §6): find its sessions, pair each with its force-platform file and
its subject, and say what is missing — without stopping at the first problem.

```
DIR/subjects.csv          subject, weight_kg, height_cm, age, sex, ...
DIR/sessions/*.h5         mat sessions; metadata holds subject and trial (a recording that was
                          not closed, *.h5.journal alone, is listed with a status saying that
                          ``psmat repair`` finishes it)
DIR/forceplate/*.csv      force-platform CoP, same stem as the session it belongs to (also .tsv,
                          .txt; a stem that differs only in case is taken, as Windows would; two
                          files for one session are a problem, neither is used)
DIR/calibration/*.json    optional, per box serial number
DIR/events/*.csv          optional, same stem as the session: an experimenter's log of markers
                          (time_s,label on the session's host clock, psmat.balance.load_events_csv)
                          used instead of the session's own markers to cut its trial into conditions
DIR/results/              written by ``psmat study run``
DIR/truth/                simulated studies only; never read here
```
"""

from __future__ import annotations

import csv
import io
import os
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .._folders import companion, data_files, hidden, nested, workbook_hint
from .._text import NotTextError, read_text
from ..units import header_unit, kg_per_unit, n_from_kg

if TYPE_CHECKING:  # pragma: no cover
    from ..circuit import Circuit

__all__ = ["Subject", "StudyItem", "StudyLayout", "read_subjects", "scan_subjects", "SubjectsFile", "find_study"]


@dataclass(frozen=True)
class Subject:
    """One row of ``subjects.csv``: the id, the body weight and whatever else it holds."""

    subject: str
    weight_kg: float
    extra: dict[str, str] = field(default_factory=dict)

    @property
    def weight_n(self) -> float:
        """Body weight in N (standard gravity)."""
        return n_from_kg(self.weight_kg)


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
    #: the recording was not closed (only its journal is there): why, and the psmat repair command
    #: that finishes it (:func:`psmat.io.session.unfinished_reason`); such a session is not processed
    not_closed: str | None = None
    #: ``events/<stem>.csv`` when the study has one (its markers replace the session's)
    events: Path | None = None
    #: why that file is not used (:func:`events_problem`; then the trial gets no condition), or None
    events_unusable: str | None = None
    #: the box serial in the session's device description (None: unreadable or absent), read with the
    #: rest of its metadata so that a run does not open the file again to find its calibration
    serial: str | None = None
    #: the circuit the session's own description and stored calibration give (None: not a mat's
    #: session, or unreadable), for the run's estimate of its work (:mod:`psmat.study` (``_order.py``))
    circuit: Circuit | None = None

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
    #: subjects whose row of subjects.csv was refused, and why (:func:`scan_subjects`)
    refused_subjects: dict[str, str] = field(default_factory=dict)

    @property
    def results(self) -> Path:
        return self.root / "results"

    @property
    def simulated(self) -> bool:
        """Every session says a simulator wrote it (its metadata, not ``truth/``)."""
        return bool(self.items) and all(i.simulated for i in self.items)


def read_subjects(path: str | os.PathLike[str]) -> dict[str, Subject]:
    """``subjects.csv`` → {subject id: Subject}; the first bad row (a missing or bad weight, an id
    twice) or an unreadable file is one clear ValueError. :func:`find_study` instead keeps the good
    rows (:func:`scan_subjects`)."""
    found = scan_subjects(path)
    if found.problems:
        raise ValueError(found.problems[0])
    return found.subjects


@dataclass
class SubjectsFile:
    """What :func:`scan_subjects` read: the good rows, and each bad row's problem (one line)."""

    subjects: dict[str, Subject]
    #: the problem of each subject id whose row was refused (that subject has no body weight)
    refused: dict[str, str]
    #: every problem, in file order (a file that cannot be read at all is one)
    problems: list[str]


def scan_subjects(path: str | os.PathLike[str]) -> SubjectsFile:
    """``subjects.csv`` row by row: a bad row is refused alone, with its line number and why.

    The file is text as spreadsheets save it (UTF-8 with or without a byte-order mark, UTF-16 with
    one, or Windows-1252), its fields separated by commas or, as a spreadsheet in a European locale
    writes it, by semicolons or tabs with decimal commas (``S01;67,5``); it needs the columns
    ``subject`` and ``weight_kg`` (kg, in (0, 500)), written as people write them (``Subject``,
    ``Weight (kg)``; ``weight_lb`` in pounds: :func:`psmat.units.header_unit`). A row whose id appears
    twice is refused with the other: which weight is right is not known.
    """
    path = Path(path)
    subjects: dict[str, Subject] = {}
    refused: dict[str, str] = {}
    problems: list[str] = []
    first_line: dict[str, int] = {}

    def refuse(sid: str, line: int, why: str) -> None:
        msg = f"{path}:{line}: {why}"
        problems.append(msg)
        if sid:
            refused.setdefault(sid, msg)
            subjects.pop(sid, None)

    try:
        with io.StringIO(read_text(path), newline="") as fh:
            # tabs or semicolons in the header: a spreadsheet's "text" or European CSV, whose numbers
            # have decimal commas
            head = fh.readline()
            delim = "\t" if "\t" in head else ";" if ";" in head else ","
            fh.seek(0)
            reader = csv.DictReader(fh, restkey="\0extra", delimiter=delim)
            names = [(n or "").strip() for n in (reader.fieldnames or [])]
            try:
                sname, wname, kg_per = _subject_columns(names)
            except ValueError as exc:
                return SubjectsFile({}, {}, [f"{path}: {exc}"])
            for row in reader:
                k = reader.line_num
                extra = row.pop("\0extra", None)
                row = {(a or "").strip(): (b or "").strip() for a, b in row.items()}
                sid = row.pop(sname)
                if not sid:
                    refuse("", k, "empty subject id: the row is left out")
                    continue
                if sid in first_line:
                    refuse(sid, k, f"subject {sid!r} appears twice (lines {first_line[sid]} and {k}): "
                                   "neither row is used")
                    continue
                first_line[sid] = k
                if extra:
                    refuse(sid, k, f"{len(names) + len(extra)} fields for {len(names)} columns: the row is left out")
                    continue
                text = row.pop(wname)
                try:
                    w = float(text.replace(",", ".") if delim != "," else text) * kg_per
                except ValueError:
                    refuse(sid, k, f"{wname} of {sid!r} is not a number ({text!r}): the row is left out")
                    continue
                if not 0 < w < 500:
                    refuse(sid, k, f"{wname} of {sid!r} is {text}" + (f" = {w:g} kg" if kg_per != 1 else "")
                           + "; expected kg in (0, 500): the row is left out")
                    continue
                if sid not in refused:
                    subjects[sid] = Subject(sid, w, row)
    except NotTextError as exc:
        return SubjectsFile({}, {}, [f"{path} {exc}; save it as CSV"])
    except csv.Error as exc:
        return SubjectsFile({}, {}, [f"{path} is not a readable CSV file ({exc})"])
    return SubjectsFile(subjects, refused, problems)


_SUBJECT = ("subject", "subject_id", "participant", "participant_id")
_WEIGHT = ("weight", "mass", "body_weight", "body_mass", "bodyweight", "bodymass")


def _subject_columns(names: list[str]) -> tuple[str, str, float]:
    """(the subject id's column, the body weight's column, kg per its unit) of subjects.csv's header, as
    a person writes it (``Subject``, ``Weight (kg)``, ``weight_lb``); ValueError (one line) without them."""
    ids = [n for n in names if header_unit(n, _SUBJECT) is not None]
    weights = {n: w[1] for n in names if (w := header_unit(n, _WEIGHT)) is not None}
    if len(ids) != 1:
        raise ValueError(f"needs one column 'subject' (the subject's id), has {names}")
    if len(weights) != 1:
        raise ValueError(f"needs one column 'weight_kg' (the body weight; or weight_lb), has {names}")
    (name, unit), = weights.items()
    if unit is None:
        raise ValueError(f"the column {name!r} names no unit: call it weight_kg or weight_lb")
    try:
        return ids[0], name, kg_per_unit(unit)
    except ValueError as exc:
        raise ValueError(f"the column {name!r}: {exc}") from None


#: what :func:`_session_meta` reads from a session file
SessionMeta = tuple[str | None, str | None, str | None, bool, str | None, str | None, "Circuit | None", bool]


def _session_meta(path: Path) -> SessionMeta:
    """(subject, trial, problem, simulated, not closed, box serial, circuit, whether it is a mat's session
    that stores no calibration of its own) from a session's metadata (the loader checks the file's structure and metadata but reads no frame, a third of
    the cost: a damaged chunk is found, and noted, when the session is processed; it reads the
    journal of a recording that was not closed)."""
    from ..io import SessionFormatError, load_session
    from ..io.session import not_closed_line, unfinished_reason
    from ..process import session_circuit

    try:
        s = load_session(path, frames=False)
    except (SessionFormatError, OSError) as exc:
        not_closed = not_closed_line(path) if not path.exists() else None
        return None, None, f"unreadable session: {exc}", False, not_closed, None, None, False
    meta = s.metadata
    subject = meta.get("subject")
    trial = meta.get("trial")
    serial = s.device.get("serial")
    try:
        circuit = session_circuit(s) if s.kind == "psm" else None
    except (ValueError, TypeError, KeyError):  # a description the processing will refuse, with its reason
        circuit = None
    return ((None if subject is None else str(subject)), (None if trial is None else str(trial)), None,
            meta.get("simulated") is True, unfinished_reason(path, s), None if serial in (None, "") else str(serial),
            circuit, s.kind == "psm" and s.calibration is None)


def find_study(root: str | os.PathLike[str]) -> StudyLayout:
    """Discover a study folder; problems are collected per session, never raised per session.

    Raises
    ------
    FileNotFoundError
        ``root`` or ``root/sessions`` does not exist.
    """
    return discover(root)


def discover(root: str | os.PathLike[str], known: Callable[[Path], SessionMeta | None] | None = None,
             read: dict[Path, SessionMeta] | None = None) -> StudyLayout:
    """:func:`find_study`, with each session's metadata from ``known(path)`` where it gives them
    (``psmat study run``'s record of earlier runs, :mod:`psmat.study` (``_discovery.py``)), else read
    from the file and, with ``read``, put there by path."""
    from ..io.session import journal_only

    root = Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"study folder not found: {root}")
    sessions = root / "sessions"
    if not sessions.is_dir():
        raise FileNotFoundError(f"{root} has no sessions/ folder (docs/spec.md §6 study layout)")
    problems: list[str] = []
    subjects: dict[str, Subject] = {}
    refused: dict[str, str] = {}
    # subjects.csv, or as a spreadsheet or Windows names it: Subjects.CSV, subjects.txt (tab-separated)
    tables = data_files(root, (".csv", ".tsv", ".txt"))
    sub_csv, two = companion("subjects", tables, "subjects")
    if sub_csv is not None:
        found = scan_subjects(sub_csv)  # a bad row costs its own subject only
        subjects, refused = found.subjects, found.refused
        problems += found.problems
    elif two:
        problems.append(f"{len(tables['subjects'])} subjects files ({', '.join(p.name for p in tables['subjects'])}): "
                        "which one holds the study's subjects is not known: keep one; no body weights")
    else:
        book = workbook_hint(root, "subjects")
        problems.append(f"{root / 'subjects.csv'} not found: no body weights" + (f"; {book}" if book else ""))
    plates = data_files(root / "forceplate", PLATFORM_SUFFIXES)
    cal = {p.stem: p for p in sorted((root / "calibration").glob("*.json")) if not hidden(p)}
    logs = data_files(root / "events", (".csv",))
    problems += nested(root, (("sessions", (".h5",)), ("forceplate", PLATFORM_SUFFIXES), ("events", (".csv",))))
    items = []
    found = {*sessions.glob("*.h5"), *journal_only(sessions)}  # journal-only: never skipped silently
    for s in sorted(p for p in found if not hidden(p)):
        meta = known(s) if known is not None else None
        if meta is None:
            meta = _session_meta(s)
            if read is not None:
                read[s] = meta
        subject, trial, problem, simulated, not_closed, serial, circuit, uncalibrated = meta
        plate, plate_problem = companion(s.stem, plates, "force-platform")
        log, log_problem = companion(s.stem, logs, "events")
        item = StudyItem(s.stem, s, plate, subject, trial, simulated=simulated, not_closed=not_closed,
                         events=log, serial=serial, circuit=circuit)
        if log is None and not log_problem:  # an experimenter's log kept as a workbook
            log_problem = workbook_hint(root / "events", s.stem, "events/") or None
        if log_problem:  # which markers are right is not known: none are used
            item.problems.append(f"events file not used, no conditions: {log_problem}")
            item.events_unusable = item.problems[-1]
        if item.events is not None and (bad := events_problem(item.events, None if problem else s)):
            item.problems.append(bad)
            item.events_unusable = bad
        if not_closed:
            item.problems.append(not_closed)
        if problem:
            item.problems.append(problem)
        else:
            if subject is None:
                item.problems.append("session metadata has no subject")
            elif subject in refused:
                item.problems.append(refused[subject])
            elif subject not in subjects:
                alike = [k for k in subjects if k.casefold() == subject.casefold()]
                item.problems.append(f"subject {subject!r} is not in subjects.csv" + (
                    f" (ids are matched exactly; it has {', '.join(map(repr, alike))})" if alike else ""))
            if trial is None:
                item.problems.append("session metadata has no trial")
        if serial is not None and cal and serial not in cal:  # calibrated boxes, but not this one by name
            alike = [k for k in cal if k.casefold() == serial.casefold()]
            if len(alike) == 1:  # a stem that differs only in case, as for the platform files
                cal[serial] = cal[alike[0]]
            elif uncalibrated:  # (a session that stores its calibration is read with it)
                have = sorted({p.name for p in cal.values()})
                item.problems.append(f"no calibration/{serial}.json for its box {serial!r} (calibration/ has "
                                     f"{', '.join(have[:3])}{', ...' if len(have) > 3 else ''}), and the session "
                                     "stores none: the profile's nominal circuit is used")
        if plate_problem:
            item.problems.append(plate_problem)
        elif item.forceplate is None:
            book = workbook_hint(root / "forceplate", s.stem, "forceplate/")
            item.problems.append(f"no force-platform file forceplate/{s.stem}.csv" + (f"; {book}" if book else ""))
        items.append(item)
    if not items:
        problems.append(f"{sessions} holds no *.h5 session")
    problems += _spelled_apart([i.trial for i in items], "trials")
    problems += _spelled_apart([i.subject for i in items], "subjects")
    told = {refused[i.subject] for i in items if i.subject in refused}  # said by their sessions, not twice
    problems = [p for p in problems if p not in told]
    return StudyLayout(root, subjects, items, cal, problems, refused)


#: suffixes of force-platform files (any case) under forceplate/
PLATFORM_SUFFIXES = (".csv", ".tsv", ".txt")


def _spelled_apart(names: list[str | None], what: str) -> list[str]:
    """A problem line for each set of the sessions' ``names`` (trials or subjects) that differ only in
    case, spaces, ``-`` or ``_`` (``Right-leg``, ``right leg``): the study keeps them apart, as written,
    and summarises them apart; the line says so, so that they are renamed if they are one."""
    groups: dict[str, set[str]] = {}
    for n in names:
        if n is not None:
            groups.setdefault(re.sub(r"[\s_\-]+", "", n.casefold()), set()).add(n)
    return [f"{what} {', '.join(map(repr, sorted(g)))} differ only in case or separators: they are kept and "
            "summarised apart; if they are one, name them alike in the sessions' metadata"
            for g in groups.values() if len(g) > 1]


def events_problem(path: Path, session: Path | None = None) -> str | None:
    """Why an events file cannot be used (one line: :func:`psmat.balance.load_events_csv`'s), or None.

    With ``session``: also when its markers are on another clock than the session's recording
    (:func:`psmat.balance.off_the_clock`, against the host times of its first and last frames,
    :func:`psmat.io.session.host_time_span`).
    """
    from ..balance import NEAR_S, off_the_clock
    from ..io.session import host_time_span

    span = None if session is None else host_time_span(session)
    try:
        marks = session_events(path, session, span)
    except (ValueError, OSError) as exc:
        return f"events file not used, no conditions: {' '.join(str(exc).split())}"
    times = [t for t, _ in marks]
    if span is not None and off_the_clock(times, *span):
        return (f"events file not used, no conditions: none of the {len(marks)} markers of {path} "
                f"({min(times):.6g}-{max(times):.6g} s) falls within {NEAR_S / 3600:g} h of the recording "
                f"({span[0]:.6f}-{span[1]:.6f} s on the session's host clock); write their times on that clock "
                "(the time_s of psmat's own markers), not from the start of the recording")
    return None


def session_events(path: Path, session: Path | None, span: tuple[float, float] | None = None
                   ) -> list[tuple[float, str]]:
    """The markers of the events file ``path`` as host times of ``session``: wall-clock times on its
    computer's clock (its ``utc_offset_s``) and day (its first frame, ``span[0]``, else read),
    :func:`psmat.balance.load_events_csv`; raises as it does."""
    from ..balance import load_events_csv
    from ..io.session import host_time_span, utc_offset_of

    if session is None:
        return load_events_csv(path)
    span = span if span is not None else host_time_span(session)
    return load_events_csv(path, utc_offset_s=utc_offset_of(session), near_s=None if span is None else span[0])


def describe(layout: StudyLayout) -> dict[str, Any]:
    """Counts for a progress line: sessions, ready, with problems."""
    ready = sum(1 for i in layout.items if i.ok)
    return {"sessions": len(layout.items), "ready": ready, "with_problems": len(layout.items) - ready}
