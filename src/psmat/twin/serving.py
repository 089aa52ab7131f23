"""What every served twin shares (docs/spec.md §5): the link to the host, the queue in front of it,
fault injection and the counters, and the serving thread's lifecycle.

:class:`LinkServer` is the base of :class:`~psmat.twin.serial_twin.SerialTwin` (the firmware core
compiled for the host) and :class:`~psmat.twin.emulated.EmulatedTwin` (the firmware image in the
emulator): a subclass makes the device's bytes and calls :meth:`LinkServer._send` with them, reads
the host's bytes with :meth:`LinkServer._poll_link`, and implements ``_serve`` (the loop the thread
runs until :meth:`LinkServer.stop`).

* :class:`Faults` — bit flips, dropped bytes, stalls and a disconnect, for robustness tests;
* :class:`TwinStats` — what was sent, dropped and corrupted.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field

import numpy as np

from .pty_link import PtyLink, pty_available
from .tcp_link import TcpLink

__all__ = ["Faults", "TwinStats", "LinkServer"]


@dataclass
class Faults:
    """Corruption of the byte stream (all off by default).

    Parameters
    ----------
    bit_flip : float
        Probability that a byte has one bit flipped.
    drop_byte : float
        Probability that a byte is lost.
    stall_every_s, stall_s : float
        Every ``stall_every_s`` seconds the link is silent for ``stall_s`` (0 = never).
    disconnect_after_s : float or None
        Close the port (the pty, or the TCP listener and its host) after this many seconds of serving.
    seed : int
    """

    bit_flip: float = 0.0
    drop_byte: float = 0.0
    stall_every_s: float = 0.0
    stall_s: float = 0.0
    disconnect_after_s: float | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        if not (0 <= self.bit_flip <= 1 and 0 <= self.drop_byte <= 1):
            raise ValueError("bit_flip and drop_byte are probabilities per byte, in [0, 1]")
        if self.stall_every_s < 0 or self.stall_s < 0:
            raise ValueError("stall_every_s and stall_s must be >= 0 s")
        self._rng = np.random.default_rng(self.seed)

    @classmethod
    def parse(cls, text: str) -> "Faults":
        """From ``"bit_flip=1e-5,drop_byte=1e-6,stall_every_s=5,stall_s=0.2,disconnect_after_s=30"``."""
        kwargs: dict[str, float] = {}
        for item in filter(None, (s.strip() for s in text.split(","))):
            key, _, value = item.partition("=")
            if key not in cls.__dataclass_fields__ or key.startswith("_"):
                raise ValueError(f"unknown fault {key!r}; known: bit_flip, drop_byte, stall_every_s, "
                                 "stall_s, disconnect_after_s, seed")
            kwargs[key] = int(value) if key == "seed" else float(value)
        return cls(**kwargs)

    @property
    def corrupts(self) -> bool:
        return self.bit_flip > 0 or self.drop_byte > 0

    def apply(self, data: bytes) -> tuple[bytes, int, int]:
        """Corrupted ``data``, bits flipped, bytes dropped."""
        if not self.corrupts or not data:
            return data, 0, 0
        a = np.frombuffer(data, np.uint8).copy()
        flips = np.flatnonzero(self._rng.random(a.size) < self.bit_flip)
        a[flips] ^= (1 << self._rng.integers(0, 8, flips.size)).astype(np.uint8)
        keep = self._rng.random(a.size) >= self.drop_byte
        return a[keep].tobytes(), int(flips.size), int(a.size - keep.sum())

    def stalled(self, t: float) -> bool:
        return self.stall_every_s > 0 and self.stall_s > 0 and (t % self.stall_every_s) < self.stall_s


@dataclass
class TwinStats:
    ticks: int = 0  # timer interrupts
    frames_sent: int = 0  # frames queued for the pty (whole)
    frames_unsent: int = 0  # frames the host did not take (buffer full, stall)
    bytes_sent: int = 0
    commands_bytes: int = 0
    bits_flipped: int = 0
    bytes_dropped: int = 0
    late_ticks: int = 0  # times the twin fell more than a period behind (the ticks missed are lost)
    errors: list[str] = field(default_factory=list)


class LinkServer:
    """A device served on a pseudo-terminal or on TCP (127.0.0.1): the link, the queue of bytes a
    slow host has not taken yet, fault injection, counters and the serving thread.

    A subclass sets ``kind`` (the device, for the pty's name and the thread's), calls
    :meth:`_open_link` in its ``__init__`` and implements ``_serve``.

    Attributes
    ----------
    port : str
        What a host opens: a path to the pty (a link in a private temporary folder, removed by
        :meth:`stop` and :meth:`disconnect`), or the pyserial URL ``socket://127.0.0.1:PORT``.
    transport : {"pty", "tcp"}
        Which of the two serves.
    faults : Faults
    stats : TwinStats
    disconnected : bool
        Whether the link was pulled (:meth:`disconnect`).
    """

    kind: str = "psm"

    def _open_link(self, faults: Faults | None, buffer_bytes: int, tcp_port: int | None) -> None:
        """The link: a pseudo-terminal where the system has them and ``tcp_port`` is None, else TCP.

        Parameters
        ----------
        faults : Faults, optional
        buffer_bytes : int
            Bytes queued for a host that is slow to read, beyond the link's own buffer; when it is
            full, packets are dropped whole and counted.
        tcp_port : int, optional
            Serve on this TCP port of 127.0.0.1 (0: a free one).
        """
        self.faults = faults or Faults()
        self.stats = TwinStats()
        if buffer_bytes < 1:
            raise ValueError("buffer_bytes must be positive")
        self.buffer_bytes = int(buffer_bytes)
        self._pending = bytearray()
        if tcp_port is None and pty_available():
            self._link: PtyLink | TcpLink = PtyLink(f"tty{self.kind.upper()}")
        else:
            self._link = TcpLink(0 if tcp_port is None else tcp_port)
        self._queued_for = self._link.connection  # the host the queued bytes are meant for
        self.port = self._link.port
        self.transport = self._link.transport
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._t0 = 0.0
        self.disconnected = False

    # -------------------------------------------------------------------- lifecycle
    def start(self):  # noqa: ANN201 - returns the subclass
        """Serve in a background thread; returns the twin."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._serve, name=f"psmat-twin-{self.kind}", daemon=True)
            self._thread.start()
        return self

    def stop(self, timeout_s: float = 2.0) -> None:
        """Stop serving: end the serving thread (waiting up to ``timeout_s`` s for it) and close the link."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout_s)
        self._release()

    def __enter__(self):  # noqa: ANN204 - returns the subclass
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def serve_forever(self) -> None:
        """Serve in the calling thread until :meth:`stop` (from another thread) or Ctrl-C."""
        try:
            self._serve()
        finally:
            self._release()

    def disconnect(self) -> None:
        """Pull the cable: the port and the pty (or the TCP listener and connection) disappear;
        the host's reads fail and it cannot open the port again."""
        self.disconnected = True
        self._stop.set()
        self._release()

    def _release(self) -> None:
        """Close the link (the pty and its path, or the sockets); idempotent, from any thread."""
        self._link.close()

    def _serve(self) -> None:
        """The serving thread's loop: each kind of server has its own (``SerialTwin`` ticks the
        host-compiled firmware core, ``EmulatedTwin`` runs the emulated image); this base serves nothing."""
        raise NotImplementedError(f"{type(self).__name__} does not say how it serves (LinkServer._serve)")

    # -------------------------------------------------------------------- the link
    def _poll_link(self, timeout_s: float) -> bytes:
        """Wait up to ``timeout_s`` s for host bytes or (bytes queued) room in the link; move queued
        bytes on; the host's bytes (empty when none came)."""
        r, w = self._link.wait(timeout_s, bool(self._pending))
        if w:
            self._flush()
        return self._link.read() if r else b""

    def _send(self, data: bytes, t: float, is_frame: bool) -> None:
        """Queue a packet for the host: whole, or (queue full, link stalled, no host on TCP) not at all."""
        if not data:
            return
        if self.faults.stalled(t) or not self._link.connected:
            self.stats.frames_unsent += is_frame
            return
        self._forget_gone_host()
        data, flipped, dropped = self.faults.apply(data)
        self.stats.bits_flipped += flipped
        self.stats.bytes_dropped += dropped
        if len(self._pending) + len(data) > self.buffer_bytes:
            self.stats.frames_unsent += is_frame  # the host is not reading: drop the packet whole
            return
        self._pending += data
        self.stats.frames_sent += is_frame
        self._flush()

    def _flush(self) -> None:
        """Move queued bytes into the link as far as it takes them (never blocks)."""
        self._forget_gone_host()
        if not self._pending:
            return
        n = self._link.write(self._pending)
        del self._pending[:n]
        self.stats.bytes_sent += n

    def _forget_gone_host(self) -> None:
        """Drop bytes queued for a TCP host that has left: the next host starts at a packet boundary."""
        if self._link.connection != self._queued_for or not self._link.connected:
            self._pending.clear()
            self._queued_for = self._link.connection
