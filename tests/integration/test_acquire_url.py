"""``open_device`` on pyserial URLs (``loop://``, ``socket://``, ``rfc2217://``) besides device paths.

The ``socket://`` peer here is a plain TCP server of the test's own on 127.0.0.1, not the
twin: what it sends is written with the protocol's reference encoder, and must come out of
the device decoded, byte for byte and frame for frame.
"""

from __future__ import annotations

import re
import socket
import threading
import time

import numpy as np
import pytest
import serial

from psmat.acquire import open_device
from psmat.acquire import open_port, read_chunk
from psmat.cli import main
from psmat.protocol import Opcode, encode_command, encode_v2
from hang_guard import HANG_GUARD_S, returns


class OneShotServer:
    """A TCP server on 127.0.0.1 that accepts one connection and sends it ``payload`` in ``parts``
    writes, once the host has written ``after`` (a device that streams after START)."""

    def __init__(self, payload: bytes, parts: int = 1, after: bytes = b"") -> None:
        self.payload, self.parts, self.after = payload, parts, after
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.url = f"socket://127.0.0.1:{self.listener.getsockname()[1]}"
        self.received = bytearray()
        self.thread = threading.Thread(target=self._serve, daemon=True)

    def __enter__(self) -> OneShotServer:
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.listener.close()
        self.thread.join(HANG_GUARD_S)

    def _serve(self) -> None:
        conn, _ = self.listener.accept()
        with conn:
            conn.settimeout(HANG_GUARD_S)
            while len(self.received) < len(self.after):
                chunk = conn.recv(len(self.after) - len(self.received))
                if not chunk:
                    return
                self.received += chunk
            for part in np.array_split(np.frombuffer(self.payload, np.uint8), self.parts):
                conn.sendall(part.tobytes())
                time.sleep(0.02)
            try:
                while chunk := conn.recv(4096):  # what the host wrote, until it closes
                    self.received += chunk
            except OSError:  # a host that never closes (a failed test): the hang guard
                pass


def test_read_chunk_takes_what_a_socket_holds_not_one_byte_at_a_time() -> None:
    payload = np.random.default_rng(7).integers(0, 256, 20_000, dtype=np.uint8).tobytes()
    # The peer streams only once the host has written (a device after START): pyserial's
    # socket:// empties the socket when it opens, so bytes sent before that would be lost.
    with OneShotServer(payload, parts=4, after=b"\x01") as server:
        port = open_port(server.url, 1_000_000)
        port.write(b"\x01")
        got, calls = bytearray(), 0
        deadline = time.monotonic() + HANG_GUARD_S
        try:
            while len(got) < len(payload) and time.monotonic() < deadline:
                got += read_chunk(port)
                calls += 1
            assert port.timeout == pytest.approx(0.05)  # the read timeout is left as it was
        finally:
            port.close()
    assert bytes(got) == payload
    assert calls < len(payload) // 100  # socket's in_waiting is 0 or 1; the bytes came in a few reads


def test_open_device_decodes_frames_from_a_socket_url() -> None:
    frames = 20
    rng = np.random.default_rng(11)
    counts = rng.integers(0, 4096, (frames, 4, 6), dtype=np.uint16)
    wire = b"".join(encode_v2(c, k, 1000 * k) for k, c in enumerate(counts))
    with OneShotServer(wire, parts=5, after=encode_command(Opcode.START)) as server:
        dev = open_device(server.url, "psm", "v2", (4, 6), identify=False)
        try:
            dev.start()   # unidentified: START is written without waiting for a reply
            parts = returns(lambda: _read_n(dev, frames), "the frames the server sent")
        finally:
            dev.close()   # writes STOP, then closes the socket
    np.testing.assert_array_equal(np.concatenate([p.frames for p in parts]), counts)
    np.testing.assert_array_equal(np.concatenate([p.seq for p in parts]), np.arange(frames))
    np.testing.assert_array_equal(np.concatenate([p.device_time_us for p in parts]), 1000 * np.arange(frames))
    # what the host wrote reached the server, as docs/protocol.md's command packets
    assert bytes(server.received) == encode_command(Opcode.START) + encode_command(Opcode.STOP)


def _read_n(dev, n: int) -> list:
    parts: list = []
    while sum(map(len, parts)) < n:
        parts.append(dev.read(n - sum(map(len, parts)), timeout_s=0.5))
    return parts


def test_loop_url_is_accepted() -> None:
    counts = np.arange(12, dtype=np.uint16).reshape(3, 4) * 300
    with open_device("loop://", "psm", "v2", (3, 4), identify=False) as dev:
        dev.serial.write(encode_v2(counts, 5, 77))
        batch = returns(lambda: dev.read(1, timeout_s=2 * HANG_GUARD_S), "the looped-back frame")
    np.testing.assert_array_equal(batch.frames[0], counts)
    assert (int(batch.seq[0]), int(batch.device_time_us[0])) == (5, 77)


@pytest.mark.parametrize("url, says", [
    ("socket://127.0.0.1", "socket://HOST:PORT"),
    ("socket://127.0.0.1:99999", "socket://HOST:PORT"),
    ("rfc2217://:2217", "rfc2217://HOST:PORT"),
    ("nope://somewhere", "protocol 'nope' not known"),
])
def test_a_malformed_url_is_one_clear_error(url: str, says: str) -> None:
    with pytest.raises(serial.SerialException) as info:
        open_device(url)
    assert says in str(info.value) and url in str(info.value) and "\n" not in str(info.value)


@pytest.fixture
def closed_port():
    """A TCP port on 127.0.0.1 that is bound but not listening: a connection is refused."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        yield s.getsockname()[1]


@pytest.mark.parametrize("scheme", ["socket", "rfc2217"])
def test_a_url_nobody_serves_is_refused(scheme: str, closed_port: int) -> None:
    url = f"{scheme}://127.0.0.1:{closed_port}"
    with pytest.raises(serial.SerialException, match=re.escape(url)):
        open_device(url)


@pytest.mark.parametrize("command", [["record", "{port}", "-o", "{out}", "--seconds", "1"], ["calibrate", "{port}"],
                                     ["view", "{port}", "--seconds", "1", "--save", "{png}"]])
def test_commands_take_urls_and_report_a_refused_one_in_one_line(command, closed_port, tmp_path, capsys,
                                                                   monkeypatch) -> None:
    monkeypatch.setenv("MPLBACKEND", "Agg")
    port = f"socket://127.0.0.1:{closed_port}"
    argv = [a.format(port=port, out=tmp_path / "x.h5", png=tmp_path / "v.png") for a in command]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and port in err[0] and err[0].startswith(f"psmat {command[0]}:")
