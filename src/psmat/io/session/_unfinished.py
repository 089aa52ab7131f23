"""Recordings that were not closed, and the one line that says how to finish them (``psmat repair``).

A recording whose writer was stopped before it closed (killed, a power cut, a crash) is its
journal ``PATH.journal`` (and its streams' ``PATH.NAME.journal``) without the finished file
``PATH``; :func:`psmat.io.load_session` reads it, :func:`psmat.io.repair_session` (``psmat repair
PATH``) writes the finished file from it. A recording that was to replace a finished file
(``psmat record --overwrite``) and did not close leaves the old file in place beside the new
recording's journal; the two are told apart by the time each was started (``created_utc``,
the same in a file and in the journal it was written from).

Every command that meets such a recording says so in one line (:func:`unfinished_line`); a study
lists the journal-only sessions of its folder (:func:`journal_only`) instead of skipping them.
"""

from __future__ import annotations

import os
from pathlib import Path

from ._journal import Journal
from ._layout import Session, SessionFormatError, journal_path
from ._reader import replacement_journal

__all__ = ["NOT_CLOSED", "repair_command", "not_closed_line", "unfinished_reason", "unfinished_line", "journal_only",
           "session_files"]

#: how every message about a recording that was not closed begins (a study's status column too)
NOT_CLOSED = "recording not closed"


def repair_command(path: str | os.PathLike[str], overwrite: bool = False) -> str:
    """The command that finishes the recording at ``path``: ``psmat repair PATH`` (``--overwrite``)."""
    return f"psmat repair {path}" + (" --overwrite" if overwrite else "")


def not_closed_line(path: str | os.PathLike[str]) -> str:
    """``recording not closed: run psmat repair PATH to finish it``."""
    return f"{NOT_CLOSED}: run {repair_command(path)} to finish it"


def unfinished_reason(path: str | os.PathLike[str], session: Session | None = None) -> str | None:
    """Why the recording at ``path`` is not finished and how to finish it (one line), or None.

    Parameters
    ----------
    path : path
        A session file (it may be missing: a journal-only recording).
    session : Session, optional
        ``path`` already loaded (:func:`psmat.io.load_session`), to spare a second read.

    Returns
    -------
    str or None
        ``recording not closed: run psmat repair PATH to finish it`` for a journal-only or
        unclosed recording; for a finished file beside another recording's journal, a line that
        says that ``psmat repair PATH --overwrite`` makes that recording the file; None otherwise.
    """
    path = Path(path)
    if session is None and not path.exists():
        return not_closed_line(path) if journal_path(path).is_file() else None
    if session is not None and not session.complete:
        return not_closed_line(path)
    j = replacement_journal(path, session)
    if j is None:
        return None
    return (f"{NOT_CLOSED}: {j.path.name} holds another recording, started {j.header.created_utc}, that was to "
            f"replace this file; run {repair_command(path, True)} to make it the file")


def unfinished_line(path: str | os.PathLike[str], session: Session | None = None) -> str | None:
    """``PATH: `` and :func:`unfinished_reason`, or None when the recording at ``path`` is finished."""
    reason = unfinished_reason(path, session)
    return None if reason is None else f"{path}: {reason}"


def session_files(path: str | os.PathLike[str]) -> list[Path]:
    """The files a session at ``path`` is made of, as a command's inputs (none may be an output):
    the file, its journal, its streams' journals ``PATH.NAME.journal`` and ``PATH.partial``."""
    import glob

    p = Path(path)
    return [p, journal_path(p), *sorted(p.parent.glob(glob.escape(p.name) + ".*.journal")),
            p.with_name(p.name + ".partial")]


def journal_only(folder: str | os.PathLike[str], pattern: str = "*.h5") -> list[Path]:
    """The session files matching ``pattern`` in ``folder`` that are missing while their journal
    ``NAME.journal`` is there (recordings that were not closed), sorted."""
    folder = Path(folder)
    out = []
    for j in folder.glob(pattern + ".journal"):
        p = j.with_name(j.name[: -len(".journal")])
        if p.exists() or not p.match(pattern):
            continue
        try:
            if Journal.open(j).stream is not None:  # the journal of a stream (a session named like s.h5.h5)
                continue
        except (SessionFormatError, OSError):
            pass  # unreadable: still a recording that was not closed (psmat repair says what is wrong)
        out.append(p)
    return sorted(out)
