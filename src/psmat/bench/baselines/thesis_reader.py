"""A thesis-style reader of v1 frames: the acquisition benchmark's baseline.

The thesis gives the device side (Code 2.1-2.2: ``INIT INIT``, the cells, their sum mod
4096; "if the signature is not right, the PC stores -1"); this reader does what that framing
allows: before every frame it waits for ``INIT INIT``, then reads the frame's fixed size and
checks the sum, a bad one stored as a missing row. When a byte is lost, that read runs into
the next frame's marker, so the next frame leaves no row at all. Independent of psmat: it
reads raw bytes and knows the framing from the thesis, not from :mod:`psmat.protocol`.
``tests/integration/test_bench_acquire.py`` checks it on a real pseudo-terminal.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np

__all__ = ["thesis_read", "thesis_read_port"]


def _read_exact(s: Any, n: int, stop: threading.Event) -> bytes | None:
    """n bytes from the port, or None when ``stop`` is set first."""
    buf = b""
    while len(buf) < n:
        if stop.is_set():
            return None
        buf += s.read(n - len(buf))
    return buf


def _sync(s: Any, stop: threading.Event) -> bool:
    """Consume bytes up to and including the next INIT INIT (0xFF 0xFF); False if stopped."""
    prev = b""
    while not stop.is_set():
        b = s.read(1)
        if prev == b == b"\xff":
            return True
        prev = b or prev
    return False


def thesis_read(s: Any, shape: tuple[int, int], stop: threading.Event, out: dict) -> None:
    """Read frames from an open port until ``stop``.

    Parameters
    ----------
    s : serial.Serial or alike
        An open port (``read(n)`` with a timeout).
    shape : tuple of int
        Rows and columns of a frame.
    stop : threading.Event
        Set to stop reading.
    out : dict
        ``out["frames"]`` (valid rows) and ``out["invalid"]`` (rows with a bad sum, which the
        thesis stores as -1), kept current while reading.
    """
    size = 2 * shape[0] * shape[1] + 2
    out.update(frames=0, invalid=0)
    while _sync(s, stop) and (frame := _read_exact(s, size, stop)) is not None:
        cells = np.frombuffer(frame[:-2], "<u2")
        check = int.from_bytes(frame[-2:], "little")
        good = int(cells.sum()) % 4096 == check and cells.max() < 4096
        out["frames" if good else "invalid"] += 1


def thesis_read_port(port: str, shape: tuple[int, int], stop: threading.Event, out: dict) -> None:
    """:func:`thesis_read` on ``port`` (a pty's path or a ``socket://`` URL), opened with pyserial."""
    import serial

    with serial.serial_for_url(port, timeout=0.2) as s:
        s.reset_input_buffer()
        thesis_read(s, shape, stop, out)
