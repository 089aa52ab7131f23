"""psmat.acquire against real pseudo-terminals driven by a paced fake device."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest
import serial

from psmat.acquire import (AcquireError, CommandRejected, CommandTimeout, DeviceDisconnected, open_device)
from psmat.acquire import IDENTIFY_FIELDS
from psmat.protocol import Opcode, Status
from hang_guard import HANG_GUARD_S, WAIT_LONGER_S, read_until_gone, returns
from test_acquire_fake import FakeDevice, daq_counts, imu_frame, psm_frame

RATE = 165.0


def _wait_until(condition, timeout: float = HANG_GUARD_S) -> None:
    """Poll ``condition()`` until true (a hang guard, not a timing claim)."""
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.01)
    assert condition(), f"condition still false after the {timeout:g} s hang guard"


def _collect(dev, n: int, timeout: float = HANG_GUARD_S):
    """Read until ``n`` frames arrived (or timeout); concatenate the batches."""
    parts = []
    got = 0
    deadline = time.monotonic() + timeout
    while got < n and time.monotonic() < deadline:
        b = dev.read(n - got, timeout_s=0.5)
        parts.append(b)
        got += len(b)
    return parts, got


def _cat(parts, name):
    return np.concatenate([getattr(p, name) for p in parts])


@pytest.mark.parametrize("protocol", [1, 2])
def test_psm_165hz_three_seconds_no_loss(protocol: int) -> None:
    n = int(RATE * 3)
    with FakeDevice(protocol=protocol, rate=RATE, n_frames=n) as fake:
        before_open = time.time()
        dev = open_device(fake.port, protocol=f"v{protocol}")
        try:
            assert dev.description["rows"] == 16 and dev.description["fw"] == "0.1.0"
            with dev:                                   # start() -> START; exit -> close()
                parts, got = _collect(dev, n)
                after_read = time.time()
                frames = _cat(parts, "frames")
                host = _cat(parts, "host_time_s")
                assert got == n
                assert frames.shape == (n, 16, 16) and frames.dtype == np.uint16
                for i in (0, 1, n // 2, n - 1):
                    np.testing.assert_array_equal(frames[i], psm_frame(i))
                # every frame in order: cell 0 of frame i is i % 4096
                np.testing.assert_array_equal(frames[:, 0, 0], np.arange(n) % 4096)
                assert _cat(parts, "valid").all()
                seq = _cat(parts, "seq")
                dt = _cat(parts, "device_time_us")
                if protocol == 2:
                    np.testing.assert_array_equal(seq, np.arange(n))
                    np.testing.assert_array_equal(dt, (np.arange(n) * 1e6 / RATE).astype(np.int64))
                else:
                    assert (seq == -1).all() and (dt == -1).all()
                # host clock: wall time at the Device's creation, then monotonic (never backwards);
                # every frame was stamped between the open and the end of the read
                assert np.all(np.diff(host) >= 0)
                assert before_open <= host[0] and host[-1] <= after_read
                s = dev.stats
                assert (s.frames, s.invalid, s.dropped_wire, s.dropped_buffer) == (n, 0, 0, 0)
                assert s.skipped_bytes == 0 and s.connected and s.last_error is None
            assert not dev.connected
            assert (Opcode.START, 0) in fake.commands and (Opcode.STOP, 0) in fake.commands
        finally:
            dev.close()


def test_identify_and_commands_round_trip() -> None:
    with FakeDevice(rate=100) as fake:
        with open_device(fake.port) as dev:
            assert dev.description == {"device": "psm", "fw": "0.1.0", "rows": 16, "cols": 16, "rate": 165,
                                       "proto": 2, "serial": "0000A1B2", "r_o": 2200.0, "v_ref": 3.3, "bits": 12}
            reply = dev.set_rate(200)
            assert reply.opcode == Opcode.SET_RATE and reply.status == Status.OK
            assert dev.description["rate"] == 200
            assert dev.cal_hold(3, 5).status == Status.OK
            assert dev.cal_resume().status == Status.OK
            with pytest.raises(CommandRejected, match="UNKNOWN_OPCODE") as info:
                dev.send_command(0x7F)
            assert info.value.reply.status == Status.UNKNOWN_OPCODE
            assert dev.send_command(0x7F, check=False).status == Status.UNKNOWN_OPCODE
            with pytest.raises(CommandRejected, match="BAD_ARGUMENT"):
                dev.send_command(Opcode.SET_PROTOCOL, 7)
            with pytest.raises(ValueError):
                dev.set_rate(0)
            with pytest.raises(ValueError):
                dev.cal_hold(16, 0)
            assert dev.read(20, timeout_s=HANG_GUARD_S).valid.all()
            assert dev.stats.replies >= 7
        assert [c for c in fake.commands if c[0] == Opcode.CAL_HOLD] == [(Opcode.CAL_HOLD, 3 << 8 | 5),
                                                                          (Opcode.CAL_HOLD, 0xFFFFFFFF)]


def test_a_second_host_on_the_same_port_is_refused_and_the_first_keeps_its_frames() -> None:
    # open_port takes pyserial's exclusive flock before touching settings or the input buffer,
    # so a second host cannot flush or read bytes meant for the first
    with FakeDevice(rate=200) as fake, open_device(fake.port) as first:
        before = first.read(20, timeout_s=HANG_GUARD_S)
        assert len(before) == 20
        with pytest.raises(serial.SerialException) as info:
            open_device(fake.port)
        message = str(info.value)
        assert "\n" not in message and fake.port in message and "in use" in message
        after = first.read(100, timeout_s=HANG_GUARD_S)
        assert len(after) == 100 and after.valid.all()
        seq = np.concatenate([before.seq, after.seq])
        np.testing.assert_array_equal(seq, seq[0] + np.arange(len(seq)))    # not one frame stolen
        assert first.stats.dropped_wire == 0 and first.stats.skipped_bytes == 0 and first.connected


def test_set_protocol_switches_decoder_mid_stream() -> None:
    with FakeDevice(protocol=2, rate=200) as fake, open_device(fake.port) as dev:
        before = dev.read(20, timeout_s=HANG_GUARD_S)
        assert len(before) == 20 and (before.seq >= 0).all()
        dev.set_protocol(1)
        assert dev.protocol == 1
        dev.read()  # whatever straddled the switch
        after = dev.read(20, timeout_s=HANG_GUARD_S)
        assert len(after) == 20 and after.valid.all() and (after.seq == -1).all()
        k = int(after.frames[0, 0, 0])
        np.testing.assert_array_equal(after.frames[:, 0, 0], (k + np.arange(20)) % 4096)
        dev.set_protocol(2)
        dev.read()
        again = dev.read(10, timeout_s=HANG_GUARD_S)
        assert len(again) == 10 and (np.diff(again.seq) == 1).all()
        assert dev.stats.invalid == 0


def test_no_identify_reply_leaves_every_field_unknown() -> None:
    with FakeDevice(identify=None, stream_on_start=False, rate=200) as fake:
        dev = open_device(fake.port, identify_timeout_s=0.2)
        try:
            assert dev.description == {"unknown": list(IDENTIFY_FIELDS["psm"]),
                                       "note": "no reply to IDENTIFY after 3 attempts of 0.2 s"}
            assert "IDENTIFY" in dev.stats.last_error
            with pytest.raises(CommandTimeout, match=r"no reply to SET_RATE \(0x03\) .* within 0.1 s"):
                dev.send_command(Opcode.SET_RATE, 100, timeout_s=0.1)
            dev.start()                          # START written without waiting for a reply
            assert len(dev.read(10, timeout_s=HANG_GUARD_S)) == 10
            assert dev.stats.ignored > 0         # streamed from power-up, before start()
        finally:
            dev.close()


def test_corrupted_bytes_become_invalid_rows() -> None:
    bad = {10, 20, 30}

    def corrupt(i: int, pkt: bytes) -> bytes:
        if i in bad:
            b = bytearray(pkt)
            b[100] ^= 0x01      # a bit error inside the payload
            return bytes(b)
        if i == 40:
            return b"\x13\x37garbage" + pkt
        return pkt

    n = 60
    for protocol in (1, 2):
        with FakeDevice(protocol=protocol, rate=400, n_frames=n, corrupt=corrupt) as fake, \
                open_device(fake.port, protocol=protocol) as dev:
            parts, got = _collect(dev, n)
            valid = _cat(parts, "valid")
            frames = _cat(parts, "frames")
            assert got == n
            assert sorted(np.flatnonzero(~valid)) == sorted(bad)
            assert (frames[~valid] == 0).all()
            good = np.flatnonzero(valid)
            np.testing.assert_array_equal(frames[good, 0, 0], good % 4096)
            s = dev.stats
            assert s.invalid == len(bad) and s.frames == n - len(bad) and s.dropped_wire == 0
            assert s.skipped_bytes == len(b"\x13\x37garbage")


def test_v2_wire_drops_are_counted() -> None:
    def drop(i: int, pkt: bytes) -> bytes:
        return b"" if i in (5, 6, 7, 30) else pkt

    with FakeDevice(rate=400, n_frames=50, corrupt=drop) as fake, open_device(fake.port) as dev:
        parts, got = _collect(dev, 46)
        seq = _cat(parts, "seq")
        assert got == 46 and 5 not in seq and 30 not in seq
        assert dev.stats.dropped_wire == 4


def test_pulled_cable_raises_device_disconnected_and_stop_is_fast() -> None:
    fake = FakeDevice(rate=200)
    dev = open_device(fake.port)
    try:
        dev.start()
        assert len(dev.read(20, timeout_s=HANG_GUARD_S)) == 20
        time.sleep(0.1)
        fake.hangup()
        # only the loss can end this wait in time: its own timeout is longer than the hang guard
        waited = returns(lambda: dev.read(10_000, timeout_s=WAIT_LONGER_S), "read woken by the pulled cable")
        assert len(waited) > 0                       # what was buffered comes back first
        _wait_until(lambda: not dev.connected)
        with pytest.raises(DeviceDisconnected, match=fake.port) as info:
            dev.read()                              # buffer empty and port gone
        assert info.value.port == fake.port
        assert "disconnected" in str(info.value) and dev.stats.last_error
        with pytest.raises(DeviceDisconnected):
            dev.set_rate(100)
        returns(lambda: (dev.stop(), dev.close()), "stop and close after the loss")
        assert dev.serial is None and not dev.connected
        with pytest.raises(AcquireError):
            dev.start()
    finally:
        dev.close()
        fake.close()


def test_waiting_command_is_woken_by_a_lost_link() -> None:
    fake = FakeDevice(identify=None, stream_on_start=False, rate=100)
    dev = open_device(fake.port, identify=False)
    try:
        import threading
        threading.Timer(0.2, fake.hangup).start()
        with pytest.raises(DeviceDisconnected):      # not CommandTimeout: its timeout outlasts the guard
            returns(lambda: dev.send_command(Opcode.IDENTIFY, timeout_s=WAIT_LONGER_S), "command woken by the loss")
    finally:
        dev.close()
        fake.close()


def test_reconnect_to_the_same_port(tmp_path) -> None:
    link = tmp_path / "ttyPSM"
    fake1 = FakeDevice(rate=200, stream_on_start=False, seq0=0)
    os.symlink(fake1.port, link)
    dev = open_device(str(link), reconnect=True, reconnect_delay_s=0.05, reconnect_max_delay_s=0.2)
    fake2 = None
    try:
        dev.start()
        _wait_until(lambda: dev.stats.buffered >= 10)
        fake1.hangup()
        _wait_until(lambda: not dev.connected)
        b = dev.read()                              # no DeviceDisconnected while reconnecting:
        assert len(b) >= 10 and np.all(np.diff(b.seq) == 1) and b.seq[-1] < 10_000    # fake1's frames
        fake2 = FakeDevice(rate=200, stream_on_start=True, seq0=10_000)
        tmp = tmp_path / "tmp-link"
        os.symlink(fake2.port, tmp)
        os.replace(tmp, link)
        _wait_until(lambda: dev.stats.reconnects > 0)
        assert dev.stats.reconnects == 1 and dev.connected
        b = dev.read(10_000, timeout_s=0.2)
        b = dev.read(10, timeout_s=HANG_GUARD_S)      # the restarted stream (START re-sent)
        assert len(b) == 10 and (b.seq >= 10_000).all()
        assert (Opcode.START, 0) in fake2.commands
        returns(dev.close, "close of a reconnected device")
        assert dev.serial is None and not dev.connected
    finally:
        dev.close()
        fake1.close()
        if fake2 is not None:
            fake2.close()


def test_reconnect_gives_up_after_bounded_attempts() -> None:
    fake = FakeDevice(rate=200)
    dev = open_device(fake.port, reconnect=True, reconnect_attempts=3, reconnect_delay_s=0.02,
                      reconnect_max_delay_s=0.05)
    try:
        dev.start()
        fake.hangup()
        with pytest.raises(DeviceDisconnected, match="gave up reconnecting after 3 attempts"):
            returns(lambda: read_until_gone(dev), "reads until the device gave up reconnecting")
        assert dev.stats.reconnects == 0
    finally:
        dev.close()
        fake.close()


def test_buffer_overflow_drops_oldest_and_counts() -> None:
    n = 200
    with FakeDevice(rate=1000, n_frames=n) as fake, open_device(fake.port, buffer_frames=32) as dev:
        fake.wait_sent(n, timeout=HANG_GUARD_S)
        _wait_until(lambda: dev.stats.frames >= n)
        s = dev.stats
        assert s.frames == n and s.dropped_buffer == n - 32 and s.buffered == 32
        b = dev.read()
        np.testing.assert_array_equal(b.seq, np.arange(n - 32, n))     # the newest survive
        assert len(dev.latest()) == 0


def test_imu_v1_and_v2_via_pty() -> None:
    for protocol in (1, 2):
        with FakeDevice(kind="imu", protocol=protocol, rate=100, n_frames=20,
                        identify="device=imu fw=0.1.0 sensors=5 rate=10") as fake, \
                open_device(fake.port, kind="imu", protocol=f"v{protocol}") as dev:
            parts, got = _collect(dev, 20)
            frames = _cat(parts, "frames")
            assert got == 20 and frames.shape == (20, 5, 3) and frames.dtype == np.float32
            np.testing.assert_array_equal(frames[7], imu_frame(7))
            assert dev.description["device"] == "imu"


def test_daq_text_device_via_pty() -> None:
    with FakeDevice(kind="daq", rate=100, n_frames=30) as fake:
        dev = open_device(fake.port, kind="daq", baudrate=115_200)
        try:
            assert dev.description == {}
            time.sleep(0.1)
            assert fake.sent == 0                      # waits for 's'
            dev.start()
            parts, got = _collect(dev, 30)
            frames = _cat(parts, "frames")
            assert got == 30 and frames.shape == (30, 10) and frames.dtype == np.uint16
            np.testing.assert_array_equal(frames[12], daq_counts(12))
            assert (_cat(parts, "seq") == -1).all() and dev.stats.invalid == 0
            dev.stop()
            _wait_until(lambda: not fake.streaming)    # 'f' arrived
            with pytest.raises(AcquireError, match="only 's'/'f'"):
                dev.send_command(Opcode.IDENTIFY)
        finally:
            dev.close()


def test_record_to_session_writer(tmp_path) -> None:
    from psmat.io import SessionWriter, load_session

    n = 100

    def drop(i: int, pkt: bytes) -> bytes:
        return b"" if i == 50 else pkt

    path = tmp_path / "s.h5"
    with FakeDevice(rate=500, n_frames=n, corrupt=drop) as fake:
        dev = open_device(fake.port)
        with SessionWriter(path, (16, 16), dev.description) as writer:
            dev.record_to(writer)
            dev.start()
            _collect(dev, n - 1)
            dev.close()                      # stores the counters
        s = load_session(path)
    assert s.n_frames == n - 1
    np.testing.assert_array_equal(s.frames[:, 0, 0], np.delete(np.arange(n), 50))
    assert s.counters["dropped_frames"] == 1
    assert s.device["serial"] == "0000A1B2"


def test_close_while_reconnecting_is_fast() -> None:
    fake = FakeDevice(rate=200)
    dev = open_device(fake.port, reconnect=True, reconnect_attempts=None, reconnect_delay_s=0.5,
                      reconnect_max_delay_s=5.0)
    try:
        dev.start()
        fake.hangup()
        _wait_until(lambda: not dev.connected)
        # the reconnect loop sleeps up to 5 s between attempts: close must cut that short
        returns(lambda: (dev.stop(), dev.close()), "stop and close while reconnecting")
        assert dev.serial is None and not dev.connected
    finally:
        dev.close()
        fake.close()


def test_cal_hold_asks_for_the_wire_position_of_a_logical_cell() -> None:
    """The box holds multiplexer channels: on a mat wired out of order (row_order[k] is the logical
    row of the k-th row on the wire) the logical cell (3, 5) is wire row 12, wire column 0 here."""
    rows = tuple(range(15, -1, -1))           # wire row k is logical row 15 - k: logical 3 is wire 12
    cols = (5,) + tuple(c for c in range(16) if c != 5)  # logical column 5 comes first on the wire
    with FakeDevice(rate=100) as fake:
        with open_device(fake.port, row_order=rows, col_order=cols) as dev:
            assert dev.cal_hold(3, 5).status == Status.OK
            assert dev.cal_resume().status == Status.OK
        assert [c for c in fake.commands if c[0] == Opcode.CAL_HOLD] == [(Opcode.CAL_HOLD, 12 << 8 | 0),
                                                                          (Opcode.CAL_HOLD, 0xFFFFFFFF)]


def test_a_port_that_cannot_be_opened_says_why(tmp_path) -> None:
    """The first day with a mat on Linux: the port is named wrong, or this user is not in the group that
    owns it (a new user is not in ``dialout``). Before, pyserial's "[Errno 13] could not open port ...:
    [Errno 13] Permission denied" without what to do. A real pty with the modes of a serial port
    (``crw-rw----``): as root, opened with the effective user id of ``nobody`` (the kernel's own check);
    as another user, its owner bits cleared."""
    import grp

    from serial.tools import list_ports

    list_ports.comports()  # (imported before any change of user id)
    missing = str(tmp_path / "ttyUSB9")
    with pytest.raises(serial.SerialException) as info:
        open_device(missing)
    assert str(info.value).startswith(f"{missing}: no such port; ")
    assert ("serial ports here: " in str(info.value)) == bool(list_ports.comports())
    master, slave = os.openpty()
    port = os.ttyname(slave)
    root = os.geteuid() == 0
    try:
        if root:  # owned by a group nobody is not in, as /dev/ttyACM0 by dialout
            os.chown(port, -1, next(g for g in range(20, 10000) if g not in (*os.getgroups(), 65534)))
        group = grp.getgrgid(os.stat(port).st_gid).gr_name
        os.chmod(port, 0o660 if root else 0o060)
        if root:  # nobody, and the group nogroup; the real ids stay root's
            os.setegid(65534)
            os.seteuid(65534)
        try:
            with pytest.raises(serial.SerialException) as info:
                open_device(port)
        finally:
            if root:
                os.seteuid(0)
                os.setegid(0)
    finally:
        os.close(slave)
        os.close(master)
    assert str(info.value) == (f"{port}: permission denied: this user may not open it; the group {group!r} may: "
                               f"`sudo usermod -aG {group} $USER`, then log out and in again")
    assert info.value.errno == 13
