"""The SHA-256 of a study's input files, started before the sessions are found, for their keys
(:mod:`psmat.study` (``_cache.py``)).

Finding the sessions reads each session file's metadata through h5py, one file after another on
this process's thread (~13 ms a file); the keys then hash every session and force-platform file
(a thesis-size study: 252 files, ~0.5 GB) and the boxes' calibrations. Hashing releases the GIL, so the files are hashed on a
few threads while the metadata are read, and the keys take the hashes that are ready: a run's
``keys`` stage (``results/timings.csv``) no longer waits for the bytes. A file is hashed
once per run either way, at about the same moment as before; a path that was not started here is
hashed when it is asked for.
"""

from __future__ import annotations

import os
import stat
import threading
from collections.abc import Iterable
from concurrent.futures import CancelledError, Future, ThreadPoolExecutor
from pathlib import Path
from types import TracebackType

from .._folders import data_files, hidden
from ._cache import file_sha256

__all__ = ["FileHashes", "signature", "study_inputs"]


def study_inputs(root: Path, platform_suffixes: tuple[str, ...]) -> list[Path]:
    """The session files (``sessions/*.h5``), force-platform files and box calibrations
    (``calibration/*.json``) of the study folder ``root`` that :func:`psmat.study.find_study` may
    list, hidden files left out, sessions first (sorted)."""
    sessions = sorted(p for p in (root / "sessions").glob("*.h5") if not hidden(p))
    plates = [p for group in data_files(root / "forceplate", platform_suffixes).values() for p in group]
    boxes = sorted(p for p in (root / "calibration").glob("*.json") if not hidden(p))
    return [*sessions, *plates, *boxes]


def signature(path: Path) -> tuple[int, ...] | None:
    """(device, inode, size, mtime ns, ctime ns) of the file ``path``; None when it is not a file."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    if not stat.S_ISREG(st.st_mode):
        return None
    return st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns


class FileHashes:
    """SHA-256 (hex) of files, hashed ahead on ``threads`` threads (a context manager: leaving it
    waits for the hashes in flight and drops those not started).

    Parameters
    ----------
    paths : iterable of path
        The files to hash ahead, in this order.
    threads : int
        Threads that hash (>= 1).
    """

    def __init__(self, paths: Iterable[str | os.PathLike[str]], threads: int) -> None:
        if threads < 1:
            raise ValueError(f"threads must be >= 1, got {threads!r}")
        self._pool = ThreadPoolExecutor(threads, thread_name_prefix="psmat-hash")
        self._ahead: dict[Path, Future[str | None]] = {}
        self._signature: dict[Path, tuple[int, ...] | None] = {}
        for p in paths:
            if (key := Path(p)) not in self._ahead:
                self._signature[key] = signature(key)  # before the hash starts (:meth:`unchanged`)
                self._ahead[key] = self._pool.submit(file_sha256, key)
        #: how many :meth:`sha` calls found their file hashed ahead, and how many hashed it then
        self.ahead = self.late = 0
        self._count = threading.Lock()  # sha() is called from several threads (the keys)

    def sha(self, path: str | os.PathLike[str] | None) -> str | None:
        """The SHA-256 of ``path``'s bytes; None for no path or a file that cannot be read (as the key
        of a session records a missing input)."""
        if path is None:
            return None
        future = self._ahead.get(Path(path))
        if future is not None and not future.cancelled():
            try:
                sha = future.result()
            except CancelledError:  # dropped by close() meanwhile: hashed below
                pass
            except OSError:
                self._counted(ahead=True)
                return None
            else:
                self._counted(ahead=True)
                return sha
        self._counted(ahead=False)
        try:
            return file_sha256(path)
        except OSError:
            return None

    def _counted(self, ahead: bool) -> None:
        with self._count:
            if ahead:
                self.ahead += 1
            else:
                self.late += 1

    def unchanged(self, path: str | os.PathLike[str]) -> bool:
        """Whether ``path`` was hashed ahead and has not been written to since: its device, inode, size,
        modification and status-change times (ns) are those it had before its hash started. A write
        moves the status-change time, which no tool sets back, so whatever was read from the file since
        then (its metadata, :mod:`psmat.study` (``_discovery.py``)) belongs to the bytes hashed."""
        key = Path(path)
        before = self._signature.get(key)
        return before is not None and signature(key) == before

    def close(self) -> None:
        """Stop: hashes not started are dropped; those in flight end (a file's read is not cut)."""
        self._pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self) -> FileHashes:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
