"""The order a run hands its sessions to the workers: the most expected work first (docs/spec.md §12).

With many workers the run ends when its last session does, so a long session handed out last
keeps every other worker waiting (the longest-processing-time rule: the longest first). What a
session costs is mostly IECM, which grows with its frames and with its loaded cells (the free
cells of each frame's problem): on the thesis-size simulated study (126 sessions, 16×16, 60 s
at 100 Hz, 2 workers) a session's time in its worker went with the share of cells above
:data:`LOADED_S` in 8 frames from its middle at a correlation of 0.95 (rotation trials 2.9 s, one-leg
trials 2.1 s), and was 1.55 s + 2.12 s × that share (least squares), hence :data:`FIXED_SHARE`.
Equal-sized files, the previous order, told those apart not at all. Replayed on that run's own
session times (:mod:`psmat.bench.study_order`, printed by ``python -m psmat.bench study``), 16
workers would finish the sessions in 19.63 s in this order against 20.87 s largest file first,
19.29 s for the longest first with the times known, and 18.92 s for an even split.

The estimate reads one chunk of each session to compute (the sessions' stored circuits, found at
discovery); a session it cannot estimate goes first, largest file first. The results never
depend on the order.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, TypeVar

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from ..circuit import Circuit


class _Session(Protocol):
    """A session to order: a :class:`psmat.study.SessionTask` or a :class:`psmat.study.StudyItem`."""

    @property
    def stem(self) -> str: ...

    @property
    def session(self) -> str | Path: ...


S = TypeVar("S", bound=_Session)

__all__ = ["LOADED_S", "FIXED_SHARE", "expected_work", "file_size", "most_work_first"]

#: a cell counts as loaded above this equivalent conductance (S): 10 kΩ
LOADED_S = 1e-4
#: a frame's work not driven by its loaded cells, in units of the work when every cell is loaded
FIXED_SHARE = 0.73


def expected_work(path: str | os.PathLike[str], circuit: Circuit) -> float | None:
    """A session's expected work (arbitrary units: frames × cells × (:data:`FIXED_SHARE` + the
    loaded share of a few frames from its middle)), or None when its file cannot give those frames."""
    from ..io.session import sample_frames

    got = sample_frames(path)
    if got is None:
        return None
    n, frames = got
    try:
        G = np.nan_to_num(circuit.conductance(frames), nan=0.0)
    except (ValueError, TypeError):  # not a mat's counts
        return None
    cells = int(np.prod(frames.shape[1:]))
    return float(n * cells * (FIXED_SHARE + np.mean(G > LOADED_S)))


def file_size(t: _Session) -> int:
    """The size of a session's file (bytes; 0 when it cannot be read)."""
    try:
        return os.stat(t.session).st_size
    except OSError:
        return 0


def most_work_first(todo: Sequence[S], circuits: Mapping[str, Circuit | None]) -> list[S]:
    """``todo`` in the order to hand it out: the sessions that cannot be estimated first (largest
    file first), then the others by :func:`expected_work`, most first; ``circuits``: each stem's
    stored circuit (None when unknown)."""

    work = {t.stem: (None if (c := circuits.get(t.stem)) is None else expected_work(t.session, c)) for t in todo}
    unknown = sorted((t for t in todo if work[t.stem] is None), key=file_size, reverse=True)
    known = sorted((t for t in todo if work[t.stem] is not None), key=lambda t: work[t.stem], reverse=True)
    return [*unknown, *known]
