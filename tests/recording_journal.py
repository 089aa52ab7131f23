"""What a running recording has journalled, for tests that act once it holds enough frames (a recorder in a
child process shows nothing else), and a hang-guarded wait for it: no claim on how fast."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from psmat.io import SessionFormatError, journal_path
from psmat.io.session import Journal

__all__ = ["GUARD_S", "journalled", "wait_until"]

GUARD_S = 60.0  # hang guard, not a duration


def journalled(out: Path) -> int:
    """Frames in the journal of the recording ``out`` so far (0 before it has an intact header)."""
    try:
        return sum(int(b.valid.shape[0]) for b in Journal.open(journal_path(out)).blocks())
    except (SessionFormatError, OSError):
        return 0


def wait_until(cond: Callable[[], object], what: str, guard_s: float = GUARD_S) -> None:
    """Poll ``cond()`` until it holds; fail with ``what`` after ``guard_s`` seconds (a hang guard)."""
    deadline = time.monotonic() + guard_s
    while not cond():
        assert time.monotonic() < deadline, what
        time.sleep(0.02)
