"""The twin on a real TCP socket on 127.0.0.1 (docs/spec.md §5), read through ``socket://`` URLs.

The frames a host decodes are compared with what the twin's source gave the firmware, tick
by tick; the commands go over the same connection; the pty-less fallback is forced by taking
``os.openpty`` away in this process, as on Windows.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import textwrap
import time
from urllib.parse import urlsplit

import numpy as np
import pytest
import serial

from psmat.acquire import DeviceDisconnected, open_device
from psmat.io import load_session
from psmat.twin import Faults, SerialTwin
from hang_guard import HANG_GUARD_S, read_until_gone, returns
from conftest import child_preexec

SHAPE = (16, 16)


def expected_counts(k: int, shape: tuple[int, int] = SHAPE) -> np.ndarray:
    """Tick ``k``'s counts: cells (0, 0) and (0, 1) hold k in base 4096, the others a draw seeded by k."""
    c = np.random.default_rng(k).integers(0, 4096, shape, dtype=np.uint16)
    c[0, 0], c[0, 1] = k % 4096, k // 4096
    return c


class CountingSource:
    """A PSM source whose k-th reading is ``expected_counts(k)``."""

    def __init__(self, shape: tuple[int, int] = SHAPE) -> None:
        self.shape = shape
        self.k = 0

    def next(self) -> np.ndarray:
        c = expected_counts(self.k, self.shape)
        self.k += 1
        return c


def _read(dev, n: int):
    """At least ``n`` frames (one batch's arrays concatenated); the hang guard fails a stalled link."""
    parts, deadline = [], time.monotonic() + HANG_GUARD_S
    while sum(map(len, parts)) < n:
        if time.monotonic() > deadline:
            pytest.fail(f"fewer than {n} frames within the {HANG_GUARD_S:g} s hang guard")
        parts.append(dev.read(n, timeout_s=0.5))
    frames = np.concatenate([p.frames for p in parts])
    seq = np.concatenate([p.seq for p in parts])
    return frames, seq, np.concatenate([p.valid for p in parts])


def _tcp_port(url: str) -> int:
    parts = urlsplit(url)
    assert parts.scheme == "socket" and parts.hostname == "127.0.0.1", url
    return int(parts.port)


@pytest.mark.parametrize("proto", ["v2", "v1"])
def test_frames_over_tcp_are_the_frames_the_twin_sent(proto: str) -> None:
    with SerialTwin("psm", 200, proto, source=CountingSource(), tcp_port=0) as twin:
        assert twin.transport == "tcp"
        _tcp_port(twin.port)
        with open_device(twin.port, "psm", proto, SHAPE) as dev:
            frames, seq, valid = _read(dev, 300)
        rest = dev.read()  # closed: what was buffered after those, so that every gap counted is seen
        st = dev.stats
    frames, seq, valid = (np.concatenate([a, b]) for a, b in
                          ((frames, rest.frames), (seq, rest.seq), (valid, rest.valid)))
    assert valid.all() and st.invalid == 0 and st.skipped_bytes == 0  # a new host starts at a packet boundary
    k = frames[:, 0, 0].astype(np.int64) + 4096 * frames[:, 0, 1].astype(np.int64)
    for tick, frame in zip(k, frames):
        np.testing.assert_array_equal(frame, expected_counts(int(tick)))
    assert np.all(np.diff(k) >= 1)  # in the order the twin ticked
    if proto == "v2":  # the device's sequence numbers advance with its ticks
        np.testing.assert_array_equal(np.diff(seq), np.diff(k))
        assert st.dropped_wire == int(np.sum(np.diff(seq) - 1))


def test_identify_start_stop_and_rate_over_tcp() -> None:
    with SerialTwin("psm", 100, "v2", scene="quiet", shape=(8, 12), serial="TCP00042", tcp_port=0) as twin:
        with open_device(twin.port, "psm", "v2", (8, 12)) as dev:
            d = dev.description
            assert dev.identified and (d["rows"], d["cols"], d["serial"]) == (8, 12, "TCP00042")
            dev.stop()  # STOP, its reply awaited: the twin no longer streams
            assert not dev.started and not twin.firmware.streaming
            sent, ticks = twin.stats.frames_sent, twin.stats.ticks
            returns(lambda: _wait_for(lambda: twin.stats.ticks >= ticks + 10), "the twin ticks while stopped")
            assert twin.stats.frames_sent == sent  # stopped: ticks, but no frame
            dev.start()  # START, its reply awaited (an error if the twin refused it)
            assert dev.started and twin.firmware.streaming
            dev.set_rate(50)
            assert twin.rate_hz == 50 and dev.description["rate"] == 50
            frames, _, valid = _read(dev, 20)
    assert frames.shape[1:] == (8, 12) and valid.all()


def _wait_for(cond) -> None:
    while not cond():
        time.sleep(0.01)


def test_one_host_at_a_time_and_the_next_one_after_it_left() -> None:
    with SerialTwin("psm", 100, "v2", scene="quiet", tcp_port=0) as twin:
        with open_device(twin.port, "psm", "v2") as first:
            # a second host is let in by the system, then closed by the twin at once
            with serial.serial_for_url(twin.port, timeout=0.05) as second:
                with pytest.raises(serial.SerialException, match="disconnected"):
                    returns(lambda: _read_forever(second), "the second host's read reports the closed socket")
            _read(first, 20)  # the first one was not disturbed
            assert first.connected and first.stats.invalid == 0
        # the first host closed its port: the next one is served, from a packet boundary
        with open_device(twin.port, "psm", "v2") as third:
            _, _, valid = _read(third, 20)
            assert valid.all() and third.stats.skipped_bytes == 0 and third.description["serial"] == "TWIN0001"


def _read_forever(port) -> None:
    while True:
        port.read(4096)


def test_a_reconnecting_host_finds_a_twin_that_came_back_on_its_port() -> None:
    """Unplug and replug: the twin goes away, one comes back on the same TCP port, and a
    device opened with ``reconnect=True`` connects again by itself."""
    first = SerialTwin("psm", 100, "v2", scene="quiet", tcp_port=0).start()
    number = _tcp_port(first.port)
    try:
        with open_device(first.port, "psm", "v2", reconnect=True, reconnect_delay_s=0.05,
                         reconnect_max_delay_s=0.2, reconnect_attempts=None) as dev:
            _read(dev, 10)
            first.stop()
            returns(lambda: _wait_for(lambda: not dev.connected), "the host sees the twin go")
            with SerialTwin("psm", 100, "v2", scene="quiet", tcp_port=number) as again:
                assert again.port == first.port
                returns(lambda: _wait_for(lambda: dev.connected), "the host connects again")
                _, _, valid = _read(dev, 20)
                assert valid.all() and dev.stats.reconnects == 1
    finally:
        first.stop()


def test_a_disconnect_closes_the_connection_and_the_port() -> None:
    # the fault counts from the twin's start, not from the connection: 2 s leave a loaded machine
    # time to connect first (0.3 s did not once in CI: "Connection refused" at the open)
    with SerialTwin("psm", 100, "v2", scene="quiet", faults=Faults(disconnect_after_s=2.0), tcp_port=0) as twin:
        with open_device(twin.port, "psm", "v2") as dev:
            with pytest.raises(DeviceDisconnected):
                returns(lambda: read_until_gone(dev), "reads until the closed connection is reported")
        assert twin.disconnected
        with pytest.raises(serial.SerialException, match="refused|actively"):  # nobody listens any more
            serial.serial_for_url(twin.port, timeout=0.05)


@pytest.mark.parametrize("end", ["stop", "disconnect"])
def test_a_gone_twins_port_never_leads_to_a_later_twin(end: str) -> None:
    first = SerialTwin("psm", 100, "v2", scene="quiet", tcp_port=0).start()
    port = first.port
    getattr(first, end)()
    first.stop()
    with SerialTwin("psm", 100, "v2", scene="quiet", tcp_port=0) as second:
        assert second.port != port
        with pytest.raises(serial.SerialException):
            serial.serial_for_url(port, timeout=0.05)


def test_a_tcp_port_out_of_range_is_refused() -> None:
    with pytest.raises(ValueError, match="0 ... 65535"):
        SerialTwin("psm", 100, "v2", scene="quiet", tcp_port=70000)


def test_without_a_pty_every_twin_serves_on_tcp(monkeypatch, tmp_path) -> None:
    """As on Windows: no ``os.openpty``; the twin, ``record --simulate`` and the benchmark's
    thesis-style reader all get a ``socket://`` URL that works."""
    from psmat.bench.acquire import thesis_run
    from psmat.cli import main

    monkeypatch.delattr(os, "openpty")
    with SerialTwin("imu", 20, "v2") as twin:
        assert twin.transport == "tcp" and twin.port.startswith("socket://127.0.0.1:")
        with open_device(twin.port, "imu", "v2") as dev:
            assert dev.description["device"] == "imu"
            _, _, valid = _read(dev, 5)
            assert valid.all()
    out = tmp_path / "s.h5"
    assert main(["record", "--simulate", "--seconds", "1", "-o", str(out)]) == 0
    s = load_session(out)
    assert s.n_frames > 0 and s.valid.all() and s.metadata["port"].startswith("socket://127.0.0.1:")
    thesis = thesis_run(1.0, 100, "")  # the thesis-style reader on the twin's URL
    assert thesis["frames"] > 0 and thesis["invalid"] == 0


#: in a fresh process: POSIX-only modules made unimportable (as on Windows, after pyserial, which
#: has its own Windows code, was imported), every psmat module imported, a twin served and read
WITHOUT_POSIX = textwrap.dedent("""
    import importlib, os, pkgutil, sys
    import serial, serial.tools.list_ports, serial.urlhandler.protocol_socket
    for name in ("termios", "tty", "pty", "fcntl"):
        sys.modules[name] = None
    del os.openpty
    import psmat
    for m in pkgutil.walk_packages(psmat.__path__, "psmat."):
        if not m.name.endswith("__main__"):
            importlib.import_module(m.name)
    from psmat.acquire import open_device
    from psmat.twin import SerialTwin
    with SerialTwin("psm", 100, "v2", scene="quiet") as twin, open_device(twin.port) as dev:
        batch = dev.read(10, timeout_s=30)
    print(twin.transport, twin.port.split(":")[0], len(batch), bool(batch.valid.all()))
""")


def test_the_package_imports_and_serves_without_posix_modules() -> None:
    proc = subprocess.run([sys.executable, "-c", WITHOUT_POSIX], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["tcp", "socket", "10", "True"]


def _psmat(*args: str, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "psmat", *args], text=True, preexec_fn=child_preexec(), **kw)


def test_simulate_tcp_prints_its_url_first_and_record_reads_it(tmp_path) -> None:
    out = tmp_path / "x.h5"
    with _psmat("simulate", "--tcp", "0", "--scene", "quiet", "--rate", "100", "--duration", "60",
                stdout=subprocess.PIPE) as sim:
        try:
            url = returns(sim.stdout.readline, "the simulator's first line").strip()
            _tcp_port(url)
            rec = subprocess.run([sys.executable, "-m", "psmat", "record", url, "--seconds", "1", "-o", str(out)],
                                 capture_output=True, text=True, timeout=120)
            assert rec.returncode == 0, rec.stderr
        finally:
            sim.terminate()  # SIGTERM ends it cleanly (Windows: killed, status 1)
            assert sim.wait(10) == 0 or os.name == "nt"
    s = load_session(out)
    assert s.n_frames > 0 and s.valid.all() and s.metadata["port"] == url
    np.testing.assert_array_equal(s.seq, s.seq[0] + np.arange(s.n_frames))  # none lost inside the recording
    assert s.device["serial"] == "TWIN0001"


def test_simulate_on_a_taken_port_is_one_clear_line() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        number = taken.getsockname()[1]
        proc = subprocess.run([sys.executable, "-m", "psmat", "simulate", "--tcp", str(number), "--duration", "5"],
                              capture_output=True, text=True, timeout=120)
    err = proc.stderr.strip().splitlines()
    assert proc.returncode == 1 and proc.stdout == ""
    assert len(err) == 1 and err[0].startswith(f"psmat simulate: cannot listen on 127.0.0.1:{number}")
