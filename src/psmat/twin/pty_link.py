"""The twin's link on a pseudo-terminal (POSIX): the host opens a path, as it opens a USB port.

The port a host opens is a link to the pty in a private temporary folder (like udev's
``/dev/serial/by-id`` names), removed when the link is closed. The system gives a freed pty
number (``/dev/pts/N``) to the next pty opened anywhere on the machine, so a host still
re-opening a vanished twin's ``/dev/pts/N`` (reconnecting, or another process) would land on
a newer twin; two hosts on one pty take each other's bytes, and pyserial then reports the
port gone. A link's path is never handed out again.

A pty buffers about 20 KB of unread data, whether or not a host has it open (the twin holds
its slave end).
"""

from __future__ import annotations

import errno
import importlib.util
import os
import select
import shutil
import tempfile
import threading
import weakref
from collections.abc import Callable

__all__ = ["PtyLink", "pty_available"]


def pty_available() -> bool:
    """Whether this system has pseudo-terminals (``os.openpty`` and ``termios``; not Windows)."""
    return hasattr(os, "openpty") and importlib.util.find_spec("termios") is not None


class PtyLink:
    """A raw pseudo-terminal whose slave end a host opens by :attr:`port`.

    Parameters
    ----------
    name : str
        File name of the link, e.g. ``ttyPSM``.

    Attributes
    ----------
    port : str
        The path a host opens (a link to ``/dev/pts/N``).
    connection : int
        Always 0: a pty has no connections to tell apart.
    """

    transport = "pty"
    connection = 0

    def __init__(self, name: str) -> None:
        import tty  # POSIX only (termios): imported here so that the package imports on Windows

        self._master: int | None
        self._slave: int | None
        self._master, self._slave = os.openpty()
        self._lock = threading.Lock()
        self._remove_port: Callable[[], object] = lambda: None
        try:
            tty.setraw(self._slave)  # no echo, no line discipline: bytes pass untouched
            os.set_blocking(self._master, False)
            link_dir = tempfile.mkdtemp(prefix="psmat-twin-")
            self._remove_port = weakref.finalize(self, shutil.rmtree, link_dir, True)  # also at exit
            self.port = os.path.join(link_dir, name)
            os.symlink(os.ttyname(self._slave), self.port)
        except BaseException:
            self.close()
            raise

    @property
    def connected(self) -> bool:
        """True: the pty takes bytes whether or not a host has it open."""
        return self._master is not None

    def wait(self, timeout: float, want_write: bool) -> tuple[bool, bool]:
        """Wait up to ``timeout`` s until the host sent bytes or (``want_write``) the pty has room.

        Returns
        -------
        (readable, writable) : tuple of bool
        """
        fd = self._master
        r, w, _ = select.select([fd], [fd] if want_write else [], [], timeout)
        return bool(r), bool(w)

    def read(self) -> bytes:
        """Bytes the host wrote (up to 4096; empty when there are none or no host has the port open)."""
        try:
            return os.read(self._master, 4096)  # type: ignore[arg-type]
        except BlockingIOError:
            return b""
        except OSError as exc:  # EIO: no host has the port open; keep serving
            if exc.errno != errno.EIO:
                raise
            return b""

    def write(self, data: bytes | bytearray) -> int:
        """Write what the pty takes now (never blocks); the number of bytes taken."""
        try:
            return os.write(self._master, data)  # type: ignore[arg-type]
        except BlockingIOError:
            return 0

    def close(self) -> None:
        """Remove the port's link, then close the pty; once, whichever thread comes first
        (a second close of a number the system has handed out again would close another file)."""
        with self._lock:
            self._remove_port()
            self._close_fds()

    def _close_fds(self) -> None:
        for name in ("_master", "_slave"):
            fd = getattr(self, name)
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
                setattr(self, name, None)
