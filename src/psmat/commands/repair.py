"""``psmat repair``: finish a recording that was not closed (docs/spec.md §6).

A recording stopped before it closed (the process killed, a power cut, a crash) is its journal
``FILE.journal``, and its other devices' ``FILE.NAME.journal``, without the finished session
file FILE. ``psmat repair FILE`` writes FILE from them (:func:`psmat.io.repair_session`: the
file is built beside FILE and moved into place when complete, then the journals are removed)
and prints what was recovered and what was lost: the frames of each device, and the loader's
notes (damaged journal records, the frames they held, a record cut short by the kill).

A finished FILE is never replaced without ``--overwrite``: when FILE is finished and its
journal holds another recording (one that was to replace FILE, e.g. ``psmat record
--overwrite``, and did not close), ``psmat repair FILE --overwrite`` makes that recording
FILE. A finished FILE with no other recording beside it is left as it is.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..io import Session

NAME = "repair"
HELP = "finish a recording that was not closed (only its journal is there): write the session file from it"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("session", metavar="FILE", help="the session file (.h5) whose journal FILE.journal is there")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a finished FILE with the recording in its journal")


def _lines(s: Session, notes: list[str]) -> list[str]:
    """What the finished file holds (frames of each device) and the loader's notes."""
    devices = [f"{s.n_frames} frames ({s.kind})"] + [f"stream {name}: {st.n_frames} frames ({st.kind})"
                                                       for name, st in s.streams.items()]
    return [f"psmat repair: {s.path} written from its journal: {', '.join(devices)}"] + [
        f"  note: {n}" for n in notes]


def run(args: argparse.Namespace) -> int:
    import sys
    from pathlib import Path

    import h5py

    from ..io import SessionFormatError, journal_path, load_session, repair_session
    from ..io.session import replacement_journal

    path = Path(args.session)

    def fail(msg: str) -> int:
        print(f"psmat repair: {msg}", file=sys.stderr)
        return 1

    if path.exists() and not path.is_file():
        return fail(f"{path} is not a file")
    try:
        before = load_session(path)
        if before.complete:
            j = replacement_journal(path, before)
            if j is None:
                jp = journal_path(path)
                left = f" (its journal {jp.name} is a leftover of this same recording)" if jp.is_file() else ""
                print(f"psmat repair: {path} is a finished recording: nothing to repair{left}")
                return 0
            if not args.overwrite:
                return fail(f"{path} is a finished recording (created {before.created_utc}); {j.path.name} holds "
                            f"another, started {j.header.created_utc}, that was to replace it: add --overwrite to "
                            "replace the file with it")
            s = repair_session(path, replace_finished=True)
            with h5py.File(path, "r") as f:  # the journal's notes, as repair_session stored them
                raw = f.attrs.get("repair_notes", "")
            notes = [n for n in (raw.decode() if isinstance(raw, bytes) else str(raw)).split("; ") if n]
        else:
            notes = list(before.notes)
            s = repair_session(path)
    except FileNotFoundError:
        return fail(f"{path}: no session file and no journal {journal_path(path).name}: nothing to repair")
    except (SessionFormatError, OSError, RuntimeError) as exc:
        return fail(" ".join(str(exc).split()))
    print("\n".join(_lines(s, notes)))
    return 0
