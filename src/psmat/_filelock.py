"""An exclusive, non-blocking lock on a file that the system releases when its holder dies.

POSIX: ``fcntl.flock``; Windows: ``msvcrt.locking`` on the file's first byte. Both locks
belong to the open file, not to the file's existence: a run that is killed (SIGKILL, the
task manager, a power cut) holds nothing afterwards, and the lock file it leaves behind
never blocks the next run. (A lock made of an ``O_EXCL`` file would have to guess whether
its writer is still alive.)
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

__all__ = ["LockHeld", "exclusive_lock"]


class LockHeld(RuntimeError):
    """Another open file (this process or another) holds the lock."""


def _lock(fd: int) -> None:
    """Take the lock on ``fd`` without waiting (the platform's module imported here, so that
    this module imports everywhere)."""
    if os.name == "nt":  # pragma: no cover - Windows
        import msvcrt

        os.lseek(fd, 0, os.SEEK_SET)  # msvcrt locks from the current position
        try:
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        except OSError:
            raise LockHeld from None
    else:
        import fcntl

        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise LockHeld from None


def _unlock(fd: int) -> None:
    if os.name == "nt":  # pragma: no cover - Windows
        import msvcrt

        os.lseek(fd, 0, os.SEEK_SET)
        msvcrt.locking(fd, msvcrt.LK_UNLCK, 1)
    else:
        import fcntl

        fcntl.flock(fd, fcntl.LOCK_UN)


@contextlib.contextmanager
def exclusive_lock(path: str | os.PathLike[str]) -> Iterator[None]:
    """Hold an exclusive lock on ``path`` (created if missing, never deleted) for the block.

    Parameters
    ----------
    path : path-like
        The lock file; its folder must exist.

    Raises
    ------
    LockHeld
        Another holder has it (no waiting).
    OSError
        The file cannot be created or opened.
    """
    fd = os.open(Path(path), os.O_RDWR | os.O_CREAT | getattr(os, "O_BINARY", 0), 0o644)
    try:
        _lock(fd)
        try:
            yield
        finally:
            _unlock(fd)
    finally:
        os.close(fd)
