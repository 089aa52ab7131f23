"""The acquisition benchmark's thesis-style reader, on a real pseudo-terminal."""

from __future__ import annotations

import os
import threading
import time

import numpy as np
import pytest
import serial

tty = pytest.importorskip("tty", reason="pseudo-terminals are POSIX only")  # Windows: no termios

from psmat.bench.baselines import thesis_read
from psmat.protocol import encode_v1


def _frames(n: int, shape: tuple[int, int]) -> list[bytes]:
    rng = np.random.default_rng(3)
    counts = rng.integers(0, 4096, (n, *shape), dtype=np.uint16)
    counts[:, 0, 0] = 100  # first cell's low byte is not INIT: a marker found is a frame's own
    return [encode_v1(c) for c in counts]


def test_thesis_reader_resyncs_on_init_init_after_a_lost_byte():
    # regression: the benchmark's "thesis-style" reader synced once and
    # never again, so one lost byte turned every later frame invalid, which the thesis does
    # not say. Reading INIT INIT before every frame costs the hit frame (a bad sum: a missing
    # row) and the next one, whose marker the fixed-size read swallowed (no row at all).
    shape = (4, 4)
    frames = _frames(10, shape)
    frames[2] = frames[2][:7] + frames[2][8:]  # one cell byte of frame 2 lost on the wire
    master, slave = os.openpty()
    tty.setraw(slave)
    port = serial.Serial(os.ttyname(slave), timeout=0.05)
    stop = threading.Event()
    out: dict = {}
    reader = threading.Thread(target=thesis_read, args=(port, shape, stop, out))
    reader.start()
    try:
        os.write(master, b"".join(frames))
        deadline = time.monotonic() + 20.0
        while out.get("frames", 0) + out.get("invalid", 0) < 9 and time.monotonic() < deadline:
            time.sleep(0.01)
    finally:
        stop.set()
        reader.join(5.0)
        port.close()
        os.close(master)
        os.close(slave)
    assert not reader.is_alive()
    assert out == {"frames": 8, "invalid": 1}  # frames 0, 1 and 4-9 valid; 2 a bad sum; 3 unseen
