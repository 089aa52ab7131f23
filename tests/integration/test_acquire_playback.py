"""A recorded session played back through the Device API (psmat.acquire.open_playback).

Real session files written with SessionWriter and read back by the playback; the expected
frames, sequence numbers, device times and validity are the ones written here. Timing is
checked one way only: a frame is never handed out before its recorded time divided by the
speed (a lower bound that a loaded machine cannot break); how late it comes is not asserted.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import pytest

from psmat.acquire import AcquireError, FrameBatch, PlaybackDevice, open_playback
from psmat.io import SessionWriter, load_session
from hang_guard import HANG_GUARD_S, WAIT_LONGER_S, returns

N = 100                 # frames
PERIOD_US = 10_000      # 100 Hz
T0_US = 7_000_000       # the device clock at the first frame (the playback counts from it)
SEQ0 = 500
INVALID = 37            # a row that failed its CRC: no seq, no device time, zeros
EPOCH = 1.7e9           # host times of the recording (s since the Unix epoch)


def _expected() -> dict[str, np.ndarray]:
    k = np.arange(N)
    frames = (k[:, None, None] * 3 + np.arange(16)[None, :, None] + np.zeros((1, 1, 4), int)).astype(np.uint16)
    valid = np.ones(N, bool)
    seq = SEQ0 + k
    dev = T0_US + PERIOD_US * k
    frames[INVALID] = 0
    valid[INVALID] = False
    seq[INVALID] = -1
    dev[INVALID] = -1
    host = EPOCH + 0.01 * k + 0.003 * (k % 3)  # USB jitter: the device clock paces the playback
    return {"frames": frames, "valid": valid, "seq": seq.astype(np.int64), "dev": dev.astype(np.int64),
            "host": host, "t_s": 0.01 * k}


@pytest.fixture(scope="module")
def session(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("playback") / "s.h5"
    e = _expected()
    with SessionWriter(path, (16, 4), device={"serial": "PLAY0001", "rate": 100, "protocol": 2},
                       metadata={"subject": "S01"}) as w:
        for a in range(0, N, 7):  # batches as a reader thread appends them
            b = slice(a, min(a + 7, N))
            w.append(e["frames"][b], e["host"][b], e["valid"][b], seq=e["seq"][b], device_time_us=e["dev"][b])
    return path


def _read_all(dev: PlaybackDevice, n: int, t_start: float | None = None, speed: float = 1.0) -> FrameBatch:
    """Read ``n`` frames; with ``t_start``, check that none came before its recorded time / speed."""
    parts: list[FrameBatch] = []
    deadline = time.monotonic() + HANG_GUARD_S
    got = 0
    while got < n:
        assert time.monotonic() < deadline, f"only {got} of {n} frames within the hang guard"
        b = dev.read(n - got, timeout_s=0.5)
        if t_start is not None and len(b):
            late = (time.monotonic() - t_start) * speed
            assert dev.times_s[dev_index(b)].max() <= late + 1e-9, "a frame came before its recorded time"
        parts.append(b)
        got += len(b)
    return _cat(parts)


def dev_index(b: FrameBatch) -> np.ndarray:
    """Frame indices of a batch of the fixture's session (from the frame contents: row 0 holds 3 k)."""
    return b.frames[:, 0, 0].astype(int) // 3


def _cat(parts: list[FrameBatch]) -> FrameBatch:
    return FrameBatch(np.concatenate([p.frames for p in parts]), np.concatenate([p.host_time_s for p in parts]),
                      np.concatenate([p.valid for p in parts]), np.concatenate([p.seq for p in parts]),
                      np.concatenate([p.device_time_us for p in parts]))


def _same_rows(b: FrameBatch, rows: np.ndarray) -> None:
    e = _expected()
    np.testing.assert_array_equal(b.frames, e["frames"][rows])
    np.testing.assert_array_equal(b.valid, e["valid"][rows])
    np.testing.assert_array_equal(b.seq, e["seq"][rows])
    np.testing.assert_array_equal(b.device_time_us, e["dev"][rows])


def test_a_session_plays_complete_in_order_at_its_recorded_times(session) -> None:
    s = load_session(session)
    t_start = time.monotonic()
    dev = open_playback(session, speed=10)
    try:
        assert dev.kind == "psm" and dev.shape == (16, 4) and dev.dtype == np.uint16
        assert dev.timing == "device_time_us" and dev.duration_s == pytest.approx(0.99)
        assert dev.description["serial"] == "PLAY0001" and dev.description["playback"] == str(session)
        b = _read_all(dev, N, t_start, speed=10)
        elapsed = time.monotonic() - t_start
        assert dev.finished
        assert len(dev.read(None, timeout_s=0.1)) == 0  # nothing after the end
    finally:
        dev.close()
    _same_rows(b, np.arange(N))
    # what the file holds, as the loader reads it
    np.testing.assert_array_equal(b.frames, s.counts)
    np.testing.assert_array_equal(b.valid, s.valid)
    np.testing.assert_array_equal(b.seq, s.seq)
    np.testing.assert_array_equal(b.device_time_us, s.device_time_us)
    # the last frame is recorded 0.99 s after the first: at 10x, no less than 0.099 s
    assert elapsed >= 0.05
    assert np.all(np.diff(b.host_time_s) >= 0) and b.host_time_s[0] > EPOCH  # the playback's clock, now
    st = dev.stats
    assert (st.frames, st.invalid, st.dropped_wire, st.dropped_buffer) == (N - 1, 1, 0, 0)


def test_pause_holds_frames_back_and_resume_continues_where_it_stopped(session) -> None:
    with open_playback(session, speed=10) as dev:
        first = _read_all(dev, 20)
        dev.pause()
        held_at = dev.position_s
        assert dev.paused and len(dev.read(None, timeout_s=0.3)) == 0 and len(dev.read(5, timeout_s=0.2)) == 0
        assert dev.position_s == held_at and not dev.finished
        dev.resume()
        rest = _read_all(dev, N - 20)
        assert dev.finished
    _same_rows(first, np.arange(20))
    _same_rows(rest, np.arange(20, N))


def test_close_wakes_a_reader_waiting_on_a_paused_playback(session) -> None:
    dev = open_playback(session, speed=10)
    dev.pause()
    timer = threading.Timer(0.2, dev.close)
    timer.start()
    try:
        b = returns(lambda: dev.read(N, timeout_s=WAIT_LONGER_S), "close() while read() waits")
    finally:
        timer.cancel()
        dev.close()
    assert len(b) == 0


def test_seek_continues_from_the_frame_recorded_there(session) -> None:
    with open_playback(session, speed=10) as dev:
        _read_all(dev, 10)
        dev.seek(0.5)
        assert dev.position_s >= 0.5
        rest = _read_all(dev, N - 50)
        assert dev.finished
        dev.seek(0.0)  # back to the start: a finished playback plays again
        assert not dev.finished
        again = _read_all(dev, 3)
    _same_rows(rest, np.arange(50, N))
    _same_rows(again, np.arange(3))


def test_a_speed_change_takes_effect_mid_way(session) -> None:
    with open_playback(session, speed=2) as dev:
        first = _read_all(dev, 10)
        dev.speed = float("inf")  # as fast as read: everything left is due now
        rest = dev.read(None)
        assert dev.finished and dev.speed == float("inf")
        for bad in (0, -1, float("nan"), "fast"):
            with pytest.raises(ValueError, match="speed"):
                dev.speed = bad
    _same_rows(first, np.arange(10))
    _same_rows(rest, np.arange(10, N))


def test_loop_starts_over(session) -> None:
    with open_playback(session, speed=float("inf"), loop=True) as dev:
        b = dev.read(250, timeout_s=HANG_GUARD_S)
        assert not dev.finished and dev.loops == 2
    _same_rows(b, np.arange(250) % N)
    t_start = time.monotonic()
    with open_playback(session, speed=20, loop=True) as dev:  # paced: one pass in 1 s / 20
        b = _read_all(dev, N + 30)
        assert not dev.finished and dev.loops == 1
        # the second pass begins one frame period after the last frame
        assert (time.monotonic() - t_start) * 20 >= 1.0 + 0.01 * 29
    _same_rows(b, np.arange(N + 30) % N)


def test_a_host_time_only_session_plays_by_its_host_times(tmp_path) -> None:
    path = tmp_path / "v1.h5"
    k = np.arange(50)
    host = EPOCH + 0.02 * k  # 50 Hz, protocol v1: no seq, no device clock
    frames = np.broadcast_to(k[:, None, None], (50, 4, 4)).astype(np.uint16)
    with SessionWriter(path, (4, 4), device={"serial": "V1", "protocol": 1}) as w:
        w.append(frames, host, np.ones(50, bool))
    assert load_session(path).device_time_us is None
    t_start = time.monotonic()
    with open_playback(path, speed=10) as dev:
        assert dev.timing == "host_time_s" and dev.duration_s == pytest.approx(0.98)
        np.testing.assert_allclose(dev.times_s, 0.02 * k, atol=1e-6)
        parts = []
        while sum(map(len, parts)) < 50:
            assert time.monotonic() - t_start < HANG_GUARD_S
            b = dev.read(50 - sum(map(len, parts)), timeout_s=0.5)
            if len(b):  # never before its host time / 10
                assert 0.02 * b.frames[:, 0, 0].max() <= (time.monotonic() - t_start) * 10 + 1e-9
            parts.append(b)
    b = _cat(parts)
    np.testing.assert_array_equal(b.frames, frames)
    assert np.all(b.seq == -1) and np.all(b.device_time_us == -1) and b.valid.all()
    assert time.monotonic() - t_start >= 0.05  # 0.98 s recorded at 10x


@pytest.mark.parametrize("kind, shape, dtype, value", [
    ("psm", (8, 8), np.uint16, 4000),
    ("imu", (5, 3), np.float32, -12.5),
    ("daq", (10,), np.uint16, 1023),
])
def test_every_kind_plays_with_its_shape_and_dtype(tmp_path, kind, shape, dtype, value) -> None:
    path = tmp_path / f"{kind}.h5"
    frames = np.full((20, *shape), value, dtype)
    frames[:, 0] = np.arange(20).reshape(20, *([1] * (len(shape) - 1)))
    with SessionWriter(path, shape, device={"serial": kind.upper()}, kind=kind) as w:
        w.append(frames, EPOCH + 0.01 * np.arange(20), np.ones(20, bool), seq=np.arange(20),
                 device_time_us=10_000 * np.arange(20))
    with open_playback(path, speed=float("inf")) as dev:
        assert (dev.kind, dev.shape, dev.dtype) == (kind, shape, np.dtype(dtype))
        b = dev.read(20, timeout_s=HANG_GUARD_S)
    assert b.frames.dtype == np.dtype(dtype)
    np.testing.assert_array_equal(b.frames, frames)
    np.testing.assert_array_equal(b.seq, np.arange(20))


def test_a_session_with_streams_plays_its_root_device(tmp_path) -> None:
    path = tmp_path / "two.h5"
    with SessionWriter(path, (4, 4), device={"serial": "MAT"}) as w:
        imu = w.add_stream("imu", kind="imu", shape=(5, 3), device={"serial": "IMU"})
        w.append(np.ones((10, 4, 4), np.uint16), EPOCH + 0.01 * np.arange(10), np.ones(10, bool))
        imu.append(np.zeros((3, 5, 3), np.float32), EPOCH + 0.03 * np.arange(3), np.ones(3, bool))
    with open_playback(path, speed=float("inf")) as dev:
        assert dev.kind == "psm" and dev.streams_left_out == ["imu"]
        assert len(dev.read(None)) == 10


def test_a_replay_is_not_recorded_again(session, tmp_path) -> None:
    with open_playback(session, start=False) as dev, \
            SessionWriter(tmp_path / "copy.h5", (16, 4), device={}) as w:
        with pytest.raises(AcquireError) as err:
            dev.record_to(w)
    assert "not recorded again" in str(err.value) and "\n" not in str(err.value)


def test_not_started_plays_nothing_and_a_missing_file_is_named(session, tmp_path) -> None:
    dev = open_playback(session, start=False)
    try:
        assert not dev.started and len(dev.read(None, timeout_s=0.2)) == 0 and dev.position_s == 0.0
        dev.start()
        assert len(dev.read(1, timeout_s=HANG_GUARD_S)) == 1
    finally:
        dev.close()
    with pytest.raises(FileNotFoundError, match="none.h5"):
        open_playback(tmp_path / "none.h5")
