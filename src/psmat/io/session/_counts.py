"""How many frames a recording holds, lost and invalid, derived from the rows themselves.

One definition, used by ``psmat record``'s summary, by ``psmat info`` and by the counters a
recording stores (:class:`psmat.acquire.SessionRecorder`), so that they cannot
disagree: each counts the rows that are in the file.

* ``invalid``: rows whose ``valid`` flag is 0 (a frame that failed its check on the wire,
  kept as a placeholder, or lost to a damaged chunk of the file);
* ``lost``: frames the device numbered that have no row at all. Between two rows with known
  sequence numbers ``s_i`` (row ``i``) and ``s_j`` (row ``j > i``), ``s_j - s_i - 1`` frames
  were sent, ``j - i - 1`` rows stand for them (invalid ones, whose numbers are unknown),
  so ``max(s_j - s_i - (j - i), 0)`` are lost. Sequence numbers are uint32 on the wire
  (docs/protocol.md): differences are taken modulo 2**32, and one of 2**31 or more means the
  device restarted (``restarts``), not a loss. Without sequence numbers (protocol v1, the
  DAQ) ``lost`` is None: it cannot be known.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

_WRAP = 1 << 32
_HALF = 1 << 31


@dataclass(frozen=True)
class RowCounts:
    """What the rows of a recording say (module docstring); ``lost`` None without sequence numbers."""

    frames: int
    invalid: int
    lost: int | None
    restarts: int
    first_seq: int | None
    last_seq: int | None


class RowTally:
    """:class:`RowCounts` of rows fed in order, a batch at a time (what a recorder has appended so far)."""

    def __init__(self) -> None:
        self.frames = 0
        self.invalid = 0
        self.lost = 0
        self.restarts = 0
        self.first_seq: int | None = None
        self._last: tuple[int, int] | None = None  # (row, seq) of the last row with a known sequence number

    def add(self, valid: ArrayLike, seq: ArrayLike | None = None) -> RowTally:
        """The next rows: their ``valid`` flags and sequence numbers (-1 or None: unknown)."""
        v = np.asarray(valid).astype(bool).reshape(-1)
        n = v.size
        self.invalid += int(n - np.count_nonzero(v))
        if seq is not None:
            s = np.asarray(seq, np.int64).reshape(-1)
            if s.size != n:
                raise ValueError(f"valid has {n} rows, seq {s.size}")
            rows = np.flatnonzero(s >= 0)
            if rows.size:
                pos = rows + self.frames
                sq = s[rows]
                if self._last is not None:
                    pos = np.concatenate(([self._last[0]], pos))
                    sq = np.concatenate(([self._last[1]], sq))
                elif self.first_seq is None:
                    self.first_seq = int(sq[0])
                gap = (np.diff(sq) - 1) % _WRAP  # frames sent between two numbered rows
                fwd = gap < _HALF
                self.lost += int(np.clip(gap[fwd] - (np.diff(pos)[fwd] - 1), 0, None).sum())
                self.restarts += int(np.count_nonzero(~fwd))
                self._last = (int(pos[-1]), int(sq[-1]))
        self.frames += n
        return self

    @property
    def counts(self) -> RowCounts:
        numbered = self._last is not None
        return RowCounts(frames=self.frames, invalid=self.invalid, lost=self.lost if numbered else None,
                         restarts=self.restarts, first_seq=self.first_seq,
                         last_seq=self._last[1] if numbered else None)  # type: ignore[index]


def row_counts(session: Any) -> RowCounts:
    """:class:`RowCounts` of a loaded :class:`~psmat.io.Session` (or anything with ``valid`` and ``seq``)."""
    return RowTally().add(session.valid, session.seq).counts
