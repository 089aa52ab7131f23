"""Frames lost on the wire are the sequence gaps inside what was received.

A device that streamed while nobody read it has a hole in its sequence numbers before the
host ever buffered a frame; that hole is not a loss of the recording.
"""

from __future__ import annotations

import time

import numpy as np

from psmat.acquire import open_device
from psmat.twin import SerialTwin
from test_acquire_fake import FakeDevice


def _read(dev, n: int, timeout: float = 30.0):  # a hang guard: returns once n frames arrived
    seq = []
    deadline = time.monotonic() + timeout
    while len(seq) < n and time.monotonic() < deadline:
        seq.extend(dev.read(n - len(seq), timeout_s=0.5).seq.tolist())
    return np.asarray(seq)


def _holes(seq: np.ndarray) -> int:
    """Sequence numbers missing between the first and the last received frame."""
    return int(np.sum(np.diff(seq) - 1))


def test_a_hole_before_the_first_buffered_frame_is_no_loss() -> None:
    # streams from power-up; a queued frame, then 300 sequence numbers vanish, then the
    # IDENTIFY reply: the hole lies before anything the host buffers (start() follows open())
    with FakeDevice(stream_on_start=False, rate=200, seq_jump_on_identify=300) as fake:
        with open_device(fake.port) as dev:
            seq = _read(dev, 40)
        seq = np.concatenate([seq, dev.read().seq])               # closed: the rest of the buffer
        st = dev.stats
    assert len(seq) >= 40 and seq[0] > 300
    assert _holes(seq) == 0
    assert st.dropped_wire == 0
    assert st.ignored >= 1                                        # the queued frame, before start()


def test_a_twin_that_had_been_running_loses_nothing_inside_the_recording() -> None:
    # the twin streams from power-up; nobody reads, so its queue fills and it drops frames
    with SerialTwin("psm", 165, "v2", scene="quiet") as twin:
        deadline = time.monotonic() + 30.0
        while twin.stats.frames_unsent == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert twin.stats.frames_unsent > 0
        with open_device(twin.port, "psm", "v2") as dev:
            seq = _read(dev, 100)
        seq = np.concatenate([seq, dev.read().seq])               # closed: the rest of the buffer
        st = dev.stats
    assert len(seq) >= 100
    # whatever the host's speed, a loss is a hole between received sequence numbers
    assert st.dropped_wire == _holes(seq)
    assert st.dropped_buffer == 0 and st.invalid == 0
