"""SIGTERM and SIGHUP stop a command as Ctrl-C does.

By default either signal ends a Python process at once: a recording would be left as its
journal only, a writer in the middle of a file would leave a temporary one. Inside
:func:`stop_on_termination` the first SIGTERM or SIGHUP raises :class:`Terminated` (a
:class:`KeyboardInterrupt`) in the main thread instead, so the command unwinds exactly as after
Ctrl-C: ``psmat record`` stops reading and its session file is written from the journal, every
``with`` block closes what it opened. Further SIGTERM/SIGHUP while it unwinds are ignored, so
that closing the file is not cut short (SIGKILL still ends it).

A signal that the process was started ignoring (``nohup`` ignores SIGHUP) stays ignored;
SIGHUP is skipped where it does not exist (Windows). Imports nothing but the standard library.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType
from typing import Any

__all__ = ["Terminated", "stop_on_termination", "stop_requests", "STOP_SIGNALS"]

#: the signals handled, where the system has them
STOP_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


class Terminated(KeyboardInterrupt):
    """The process got SIGTERM or SIGHUP; ``signum`` says which."""

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        super().__init__(f"stopped by {signal.Signals(self.signum).name}")

    @property
    def exit_status(self) -> int:
        """128 + the signal number, as a shell reports a process the signal ended."""
        return 128 + self.signum


@contextlib.contextmanager
def stop_on_termination() -> Iterator[None]:
    """Within the block, SIGTERM and SIGHUP raise :class:`Terminated` once (see the module docstring).

    Outside the main thread (where Python cannot handle signals) it does nothing. The
    previous handlers are restored when the block ends.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    fired: list[int] = []

    def handler(signum: int, frame: FrameType | None) -> None:
        if fired:  # already unwinding: let it finish
            return
        fired.append(signum)
        raise Terminated(signum)

    previous: dict[signal.Signals, Any] = {}
    try:
        for sig in STOP_SIGNALS:
            old = signal.getsignal(sig)
            if old is signal.SIG_IGN:  # e.g. SIGHUP under nohup
                continue
            previous[sig] = old
            signal.signal(sig, handler)
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old if old is not None else signal.SIG_DFL)


@contextlib.contextmanager
def stop_requests() -> Iterator[threading.Event]:
    """Within the block, Ctrl-C, SIGTERM and SIGHUP set the returned event instead of raising.

    For a loop that can stop cleanly at its next turn (``psmat record``): an exception raised
    at an arbitrary point of the loop may leave a lock of another thread's held (a progress
    bar's, a buffer's) and hang the close that follows; setting an event cannot, as long as the
    main thread only polls it (``is_set()``) and never waits on it: the handler runs in the main
    thread, and ``Event.set`` there while that thread is inside ``Event.wait`` (which holds the
    event's lock across a call) would wait for its own lock. A second
    signal while the event is set raises :class:`KeyboardInterrupt` (stop now). Outside the
    main thread it only yields an event nobody sets. The previous handlers are restored.
    """
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return

    def handler(signum: int, frame: FrameType | None) -> None:
        if stop.is_set():
            raise KeyboardInterrupt
        stop.set()

    previous: dict[signal.Signals, Any] = {}
    try:
        for sig in (signal.SIGINT, *STOP_SIGNALS):
            old = signal.getsignal(sig)
            if old is signal.SIG_IGN:  # e.g. SIGHUP under nohup
                continue
            previous[sig] = old
            signal.signal(sig, handler)
        yield stop
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old if old is not None else signal.SIG_DFL)
