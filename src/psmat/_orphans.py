"""Worker processes that end with the process that started them.

A pool's workers (joblib's loky processes of :mod:`psmat._parallel`) are separate processes:
when the process that started them is killed outright (``kill -9``, the task manager, an
out-of-memory kill) nothing tells them, and a busy or idle worker would live on for minutes.
:func:`exit_with_parent`, run in each worker as it starts, watches the starting process from a
daemon thread and ends the worker as soon as that process is gone:

* POSIX: the worker's parent process id changes when its parent dies (it is handed to init
  or a subreaper); checked every :data:`POLL_S` s.
* Windows: the thread waits on a handle of the parent process, which is signalled when it exits.

Linux's ``prctl(PR_SET_PDEATHSIG)`` is not used there: it fires when the *thread* that started the
worker ends, and a pool may start workers from a helper thread that ends while the pool lives.
A child whose starting thread outlives it (a browser opened and closed in one ``with`` block) can
use it: :func:`parent_death_preexec`. Imports nothing but the standard library.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time
from collections.abc import Callable

__all__ = ["POLL_S", "exit_with_parent", "parent_death_preexec"]

#: how often a worker on POSIX looks at its parent (s)
POLL_S = 0.2

#: the exit status of a worker that ended because its parent was gone
EXIT_ORPHANED = 1


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it exists, owned by someone else
        return True
    return True


def _watch_posix(parent: int) -> None:
    direct = os.getppid() == parent
    while (os.getppid() == parent) if direct else _alive(parent):
        time.sleep(POLL_S)
    os._exit(EXIT_ORPHANED)


def _watch_windows(parent: int) -> None:  # pragma: no cover - Windows
    import _winapi

    synchronize = 0x00100000
    try:
        handle = _winapi.OpenProcess(synchronize, False, parent)
    except OSError:  # already gone
        os._exit(EXIT_ORPHANED)
    _winapi.WaitForSingleObject(handle, _winapi.INFINITE)
    os._exit(EXIT_ORPHANED)


def exit_with_parent(parent_pid: int) -> None:
    """In a worker process: end this process (``os._exit``) once process ``parent_pid`` is gone.

    Meant as a pool's worker initializer, with ``parent_pid`` the pid of the process that
    makes the pool (:func:`os.getpid` there). Returns at once; a daemon thread does the watching.
    """
    target = _watch_windows if os.name == "nt" else _watch_posix
    threading.Thread(target=target, args=(int(parent_pid),), name="psmat-exit-with-parent", daemon=True).start()


def parent_death_preexec(sig: int = signal.SIGTERM) -> Callable[[], None] | None:
    """A ``preexec_fn`` for :class:`subprocess.Popen`: the child gets ``sig`` when the thread that starts it
    ends, the process killed outright included (Linux's ``prctl(PR_SET_PDEATHSIG)``); None elsewhere.

    Only for a child that its starting thread outlives (the signal follows that thread, not the
    process). The signal survives ``exec`` but not ``fork``: a child that starts the real program as
    its own child must ``exec`` it. ``prctl`` is looked up here, in the parent, so that the child
    only makes the call; a parent gone before the call is seen by the child, which then signals
    itself.
    """
    if not sys.platform.startswith("linux"):
        return None
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):  # pragma: no cover - a libc without prctl
        return None
    prctl.argtypes = [ctypes.c_int, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong]
    parent = os.getpid()
    number = int(sig)

    def arm() -> None:
        prctl(1, number, 0, 0, 0)  # PR_SET_PDEATHSIG
        if os.getppid() != parent:
            os.kill(os.getpid(), number)
    return arm
