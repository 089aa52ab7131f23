"""The twin's link on TCP (every system, Windows included): the host opens ``socket://127.0.0.1:PORT``.

A listening socket on 127.0.0.1 only (never another interface), one host at a time, as a
USB port is opened by one program at a time: a host that connects while another is served
is closed at once (its pyserial port then reports ``socket disconnected``). A host that
closes its port leaves the twin serving, and the next one to connect starts at a packet
boundary; bytes the twin had queued for the one that left are dropped, as is every packet
while no host is connected (a device's USB endpoint that nobody polls).

With port 0 the system picks a free port; within one process a port number is not handed
to a second twin (as the pty link's paths are never reused), so a host still re-connecting
to a stopped twin is refused instead of landing on a newer one.
"""

from __future__ import annotations

import os
import select
import socket
import threading

__all__ = ["HOST", "TcpLink"]

#: the only address the twin listens on
HOST = "127.0.0.1"

_given: set[int] = set()  # ephemeral ports handed to twins in this process
_given_lock = threading.Lock()
_PICKS = 64  # ephemeral ports asked for at most before one given earlier is taken again


def _socket() -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if os.name == "nt":  # Windows' SO_REUSEADDR would let another program bind the same port
        s.setsockopt(socket.SOL_SOCKET, getattr(socket, "SO_EXCLUSIVEADDRUSE", socket.SO_REUSEADDR), 1)
    else:  # a restarted twin may listen again at once on a port whose old connections linger
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    return s


def _listen(port: int) -> socket.socket:
    """A non-blocking listening socket on HOST:``port`` (0: a free port not given before here)."""
    held: list[socket.socket] = []  # kept bound while another is asked, so the system picks another
    try:
        while True:
            s = _socket()
            held.append(s)
            s.bind((HOST, port))
            with _given_lock:
                fresh = port or s.getsockname()[1] not in _given or len(held) == _PICKS
                if fresh:
                    _given.add(s.getsockname()[1])
            if fresh:
                s.listen(4)
                s.setblocking(False)
                held.pop()
                return s
    finally:
        for s in held:
            s.close()


class TcpLink:
    """A TCP server on 127.0.0.1 that serves one host at a time.

    Parameters
    ----------
    port : int
        TCP port, 0 ... 65535; 0 asks the system for a free one.

    Attributes
    ----------
    port : str
        The pyserial URL a host opens: ``socket://127.0.0.1:PORT``.
    address : tuple of (str, int)
        Host and TCP port listened on.
    connection : int
        Hosts connected so far; a packet queued for one host is never sent to the next.
    refused : int
        Hosts closed because another was being served.

    Raises
    ------
    ValueError
        ``port`` out of range.
    OSError
        The port cannot be listened on (in use).
    """

    transport = "tcp"

    def __init__(self, port: int = 0) -> None:
        if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
            raise ValueError(f"a TCP port is an integer 0 ... 65535 (0: a free one), got {port!r}")
        self._lock = threading.Lock()
        self._closed = False
        self._client: socket.socket | None = None
        self._listener = _listen(port)
        host, number = self._listener.getsockname()[:2]
        self.address = (str(host), int(number))
        self.port = f"socket://{host}:{number}"
        self.connection = 0
        self.refused = 0

    @property
    def connected(self) -> bool:
        """Whether a host is connected (bytes written now reach it)."""
        return self._client is not None

    def wait(self, timeout: float, want_write: bool) -> tuple[bool, bool]:
        """Wait up to ``timeout`` s for the host's bytes, room to write (``want_write``) or a host
        connecting (accepted here).

        Returns
        -------
        (readable, writable) : tuple of bool
            About the host connected when the wait began.
        """
        client = self._client
        rlist = [self._listener] if client is None else [self._listener, client]
        wlist = [client] if want_write and client is not None else []
        r, w, _ = select.select(rlist, wlist, [], timeout)
        if client is not None and client in r:
            return True, client in w  # its bytes (or its leaving) first: a newcomer is seen next time
        if self._listener in r:
            self._accept()
        return False, client is not None and client in w and client is self._client

    def read(self) -> bytes:
        """Bytes the host sent (up to 4096); empty when there are none, no host, or it left."""
        client = self._client
        if client is None:
            return b""
        try:
            data = client.recv(4096)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:
            data = b""
        if not data:  # the host closed its port (or the connection broke)
            self._drop(client)
        return data

    def write(self, data: bytes | bytearray) -> int:
        """Send what the connection takes now (never blocks); the number of bytes taken (0
        without a host; a host that left is dropped)."""
        client = self._client
        if client is None:
            return 0
        try:
            return client.send(data)
        except (BlockingIOError, InterruptedError):
            return 0
        except OSError:
            self._drop(client)
            return 0

    def close(self) -> None:
        """Stop listening and close the host's connection (idempotent, from any thread)."""
        with self._lock:
            self._closed = True
            client, self._client = self._client, None
            for s in (client, self._listener):
                if s is not None:
                    s.close()

    def _accept(self) -> None:
        try:
            conn, _ = self._listener.accept()
        except (BlockingIOError, InterruptedError, ConnectionError):
            return
        served = self._client
        if served is not None and not _alive(served):  # the host closed its port just before
            self._drop(served)
        with self._lock:
            if self._closed or self._client is not None:
                conn.close()
                if not self._closed:
                    self.refused += 1
                return
            conn.setblocking(False)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)  # a packet goes out when written
            self._client = conn
            self.connection += 1

    def _drop(self, client: socket.socket) -> None:
        with self._lock:
            if self._client is client:
                self._client = None
        client.close()


def _alive(conn: socket.socket) -> bool:
    """Whether the peer of ``conn`` has not closed it (bytes it sent are left unread)."""
    try:
        readable, _, _ = select.select([conn], [], [], 0)
        return not readable or conn.recv(1, socket.MSG_PEEK) != b""
    except (BlockingIOError, InterruptedError):
        return True
    except OSError:
        return False
