"""psmat.acquire through pyserial's ``loop://`` (pure unit tests: no pty, no fake device)."""

from __future__ import annotations

import time

import numpy as np
import pytest

from psmat.acquire import AcquireError, CommandTimeout, Device, DeviceStats, open_device
from psmat.protocol import Opcode, encode_daq_line, encode_v2
from hang_guard import HANG_GUARD_S, returns


def _frame(i: int) -> np.ndarray:
    return np.full((16, 16), i, np.uint16)


@pytest.fixture
def loop():
    dev = open_device("loop://", identify=False)
    yield dev
    dev.close()


def test_loop_frames_round_trip(loop: Device) -> None:
    loop.start()                      # START goes into the loop too: skipped as garbage
    for i in range(5):
        loop.serial.write(encode_v2(_frame(i), 100 + i, 1000 * i))
    b = loop.read(5, timeout_s=HANG_GUARD_S)
    assert len(b) == 5
    np.testing.assert_array_equal(b.frames[:, 3, 4], np.arange(5))
    np.testing.assert_array_equal(b.seq, 100 + np.arange(5))
    assert b.frames.dtype == np.uint16 and b.host_time_s.dtype == np.float64
    assert isinstance(loop.stats, DeviceStats) and loop.stats.frames == 5
    assert loop.stats.skipped_bytes == 11       # the START command read back
    assert "loop://" in repr(loop)


def _wait_until(condition, timeout: float = HANG_GUARD_S) -> None:
    """Poll ``condition()`` until true (a hang guard, not a timing claim)."""
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.01)
    assert condition(), f"condition still false after the {timeout:g} s hang guard"


def test_read_returns_what_it_has_when_its_timeout_ends(loop: Device) -> None:
    loop.start()
    loop.serial.write(encode_v2(_frame(1), 0, 0))
    b = loop.read(10, timeout_s=0.2)              # only one frame will come
    assert len(b) == 1 and b.seq.tolist() == [0]
    assert len(loop.read()) == 0                # n=None, no timeout: what is buffered (nothing)
    assert len(loop.read(0)) == 0
    loop.read_timeout_s = 0.1
    assert len(loop.read(3)) == 0               # n without timeout: read_timeout_s, then nothing
    with pytest.raises(ValueError):
        loop.read(-1)


def test_latest_and_frames_before_start_are_ignored(loop: Device) -> None:
    loop.serial.write(encode_v2(_frame(7), 0, 0))
    _wait_until(lambda: loop.stats.ignored == 1)
    assert len(loop.read()) == 0
    loop.start()
    for i in range(3):
        loop.serial.write(encode_v2(_frame(i), i + 1, 0))
    _wait_until(lambda: loop.stats.buffered == 3)
    last = loop.latest()
    assert len(last) == 1 and last.seq[0] == 3
    assert len(loop.latest(10)) == 3 and len(loop.read()) == 3
    loop.stop()
    assert not loop.started


def test_command_timeout_message(loop: Device) -> None:
    with pytest.raises(CommandTimeout, match=r"no reply to IDENTIFY \(0x04\) from psm on loop:// within 0.05 s"):
        loop.send_command(Opcode.IDENTIFY, timeout_s=0.05)
    with pytest.raises(TimeoutError):
        loop.set_rate(100)


def test_identify_unanswered_is_recorded() -> None:
    # loop:// echoes the command, which is no reply: every field stays unknown
    with open_device("loop://", identify_timeout_s=0.1, identify_attempts=2) as dev:
        assert dev.description["unknown"][:2] == ["device", "fw"] and not dev.identified
        assert dev.description["note"] == "no reply to IDENTIFY after 2 attempts of 0.1 s"
        assert "IDENTIFY" in dev.stats.last_error and dev.stats.replies == 0


def test_daq_on_loop() -> None:
    with open_device("loop://", kind="daq") as dev:
        assert dev.shape == (10,)
        # the loop echoes start()'s "s" first: a malformed line of its own
        dev.serial.write(b"\r\n" + encode_daq_line(np.arange(10) * 3) + b"oops\r\n")
        b = dev.read(3, timeout_s=HANG_GUARD_S)
        assert b.valid.tolist() == [False, True, False]
        np.testing.assert_array_equal(b.frames[1], np.arange(10) * 3)
        assert dev.stats.invalid == 2 and (b.frames[~b.valid] == 0).all()


def test_arguments_are_checked() -> None:
    with pytest.raises(ValueError, match="kind"):
        Device("loop://", kind="mat")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="protocol"):
        Device("loop://", protocol="v3")
    with pytest.raises(ValueError, match="imu frame has shape"):
        Device("loop://", kind="imu", shape=(16, 16))
    with pytest.raises(ValueError):
        Device("loop://", shape=(0, 16))
    with pytest.raises(ValueError):
        Device("loop://", buffer_frames=0)
    with pytest.raises(AcquireError, match="not open"):
        Device("loop://").start()
    with pytest.raises(Exception):          # serial.SerialException
        open_device("/nonexistent/ttyUSB9")


def test_close_is_idempotent(loop: Device) -> None:
    loop.start()
    returns(lambda: (loop.close(), loop.close()), "close, twice")
    assert not loop.connected and loop.serial is None
    with pytest.raises(AcquireError, match="closed"):
        loop.send_command(Opcode.START)


def test_record_to_adapter_with_a_fake_writer(loop: Device) -> None:
    class Writer:
        kind, frame_shape = "psm", (16, 16)

        def __init__(self) -> None:
            self.batches: list = []
            self.counters: dict = {}

        def append(self, *args) -> None:
            self.batches.append(args)

        def set_counters(self, **kw) -> None:
            self.counters.update(kw)

    w = Writer()
    loop.record_to(w)
    loop.start()
    for i in range(4):
        loop.serial.write(encode_v2(_frame(i), i, 0))
    assert len(loop.read(4, timeout_s=HANG_GUARD_S)) == 4
    loop.stop_recording()
    assert sum(len(b[2]) for b in w.batches) == 4
    assert w.counters == {"dropped_frames": 0, "bad_frames": 0, "bytes_discarded": 11}

    class Broken(Writer):
        def append(self, *args) -> None:
            raise OSError("disk full")

    loop.record_to(Broken())
    loop.serial.write(encode_v2(_frame(9), 9, 0))
    assert len(loop.read(1, timeout_s=HANG_GUARD_S)) == 1     # acquisition goes on
    assert "disk full" in loop.stats.last_error

    class Other(Writer):
        kind = "imu"

    with pytest.raises(ValueError, match="records 'imu'"):
        loop.record_to(Other())
