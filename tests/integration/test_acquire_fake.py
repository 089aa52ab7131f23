"""A minimal fake device on a real pseudo-terminal, used by the psmat.acquire tests.

:class:`FakeDevice` opens a pty pair (both ends raw), answers v2 commands it reads from the
master with :func:`psmat.protocol.encode_reply` (or the DAQ's ``s``/``f``), and writes
frames encoded by :mod:`psmat.protocol` at a paced rate. Self-contained on purpose (the
digital twin lives in psmat.twin and is not used here). The tests at the bottom check the
fake itself through raw file descriptors.
"""

from __future__ import annotations

import os
import select
import threading
import time
from typing import Callable

import numpy as np
import pytest

tty = pytest.importorskip("tty", reason="pseudo-terminals are POSIX only")  # Windows: no termios

from psmat.protocol import (COMMAND_SIZE, SYNC, Opcode, Status, decode_command, encode_daq_line, encode_imu_v1,
                            encode_reply, encode_v1, encode_v2)

IDENTIFY_TEXT = "device=psm fw=0.1.0 rows=16 cols=16 rate=165 proto=2 serial=0000A1B2 r_o=2200 v_ref=3.3 bits=12"


def psm_frame(i: int, shape: tuple[int, int] = (16, 16)) -> np.ndarray:
    """Frame number ``i``: cell ``a`` holds ``(i + a) % 4096`` (so order is checkable)."""
    r, c = shape
    return ((i + np.arange(r * c)) % 4096).reshape(r, c).astype(np.uint16)


def imu_frame(i: int) -> np.ndarray:
    return (np.arange(15, dtype=np.float32).reshape(5, 3) + np.float32(i) * 0.5).astype(np.float32)


def daq_counts(i: int) -> np.ndarray:
    return ((i * 7 + np.arange(10) * 100) % 1024).astype(np.int64)


class FakeDevice:
    """A device behind a pty: commands in, paced frames out.

    Parameters
    ----------
    kind : {"psm", "imu", "daq"}
    protocol : {1, 2}
    rate : float
        Frames per second.
    n_frames : int or None
        Frames to send, then stay silent (None: until closed).
    stream_on_start : bool
        True: stream only after START (``s`` for the DAQ); False: from "power-up".
    identify : str or None
        IDENTIFY text; None: ignore every command (thesis firmware).
    corrupt : callable, optional
        ``corrupt(i, packet) -> bytes`` may alter frame ``i``'s bytes.
    seq0 : int
        First v2 sequence number.
    lose_commands : int
        The first this many commands are lost on the way in (a link that stalls at open):
        neither executed nor answered, counted in ``lost``.
    seq_jump_on_identify : int
        When IDENTIFY arrives while streaming: the frame still queued is sent, then this
        many sequence numbers are skipped (frames a device streaming while nobody read it
        had to drop), then the reply follows.
    """

    def __init__(self, kind: str = "psm", protocol: int = 2, rate: float = 165.0, n_frames: int | None = None,
                 stream_on_start: bool = True, identify: str | None = IDENTIFY_TEXT,
                 corrupt: Callable[[int, bytes], bytes] | None = None, seq0: int = 0,
                 shape: tuple[int, int] = (16, 16), lose_commands: int = 0, seq_jump_on_identify: int = 0) -> None:
        self.kind, self.protocol, self.rate, self.n_frames = kind, protocol, float(rate), n_frames
        self.identify, self.corrupt, self.seq0, self.shape = identify, corrupt, seq0, shape
        self.lose_commands, self.seq_jump_on_identify = lose_commands, seq_jump_on_identify
        self.lost = 0
        self.streaming = not stream_on_start
        self.master: int | None
        self.slave: int | None
        self.master, self.slave = os.openpty()
        tty.setraw(self.master)
        tty.setraw(self.slave)
        self.port = os.ttyname(self.slave)
        self.commands: list[tuple[int, int]] = []
        self.sent = 0
        self._rx = bytearray()
        self._stop = threading.Event()
        self._close_lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, name="FakeDevice", daemon=True)
        self._thread.start()

    # -- frames ---------------------------------------------------------------------------
    def packet(self, i: int) -> bytes:
        t_us = int(i * 1e6 / self.rate)
        if self.kind == "daq":
            return encode_daq_line(daq_counts(i))
        if self.kind == "imu":
            f = imu_frame(i)
            return encode_imu_v1(f) if self.protocol == 1 else encode_v2(f, self.seq0 + i, t_us, kind="imu")
        f = psm_frame(i, self.shape)
        return encode_v1(f) if self.protocol == 1 else encode_v2(f, self.seq0 + i, t_us)

    # -- commands -------------------------------------------------------------------------
    def _commands(self, data: bytes) -> None:
        if self.kind == "daq":
            for b in data:
                if b == ord("s"):
                    self.streaming = True
                elif b == ord("f"):
                    self.streaming = False
            return
        self._rx += data
        while True:
            k = self._rx.find(SYNC)
            if k < 0 or len(self._rx) - k < COMMAND_SIZE:
                if k > 0:
                    del self._rx[:k]
                return
            try:
                op, arg = decode_command(bytes(self._rx[k:k + COMMAND_SIZE]))
            except ValueError:
                del self._rx[:k + 1]
                continue
            del self._rx[:k + COMMAND_SIZE]
            if self.lost < self.lose_commands:
                self.lost += 1
                continue
            self.commands.append((int(op), arg))
            if self.identify is not None:
                self._answer(int(op), arg)

    def _answer(self, op: int, arg: int) -> None:
        status, text, switch = Status.OK, "", None
        if op == Opcode.IDENTIFY:
            text = self.identify or ""
            if self.seq_jump_on_identify and self.streaming:
                os.write(self.master, self.packet(self.sent))
                self.sent += 1
                self.seq0 += self.seq_jump_on_identify
        elif op == Opcode.START:
            self.streaming = True
        elif op == Opcode.STOP:
            self.streaming = False
        elif op == Opcode.SET_RATE:
            if 1 <= arg <= 1000:
                self.rate = float(arg)
            else:
                status = Status.BAD_ARGUMENT
        elif op == Opcode.SET_PROTOCOL:
            if arg in (1, 2):
                switch = arg
            else:
                status = Status.BAD_ARGUMENT
        elif op != Opcode.CAL_HOLD:
            status = Status.UNKNOWN_OPCODE
        os.write(self.master, encode_reply(op, status, text, seq=self.seq0 + self.sent, t_us=0))
        if switch is not None:
            self.protocol = switch

    # -- thread ---------------------------------------------------------------------------
    def _run(self) -> None:
        next_t = time.monotonic()
        try:
            while not self._stop.is_set():
                wait = max(0.0, next_t - time.monotonic()) if self.streaming else 0.01
                ready, _, _ = select.select([self.master], [], [], min(wait, 0.01))
                if ready:
                    self._commands(os.read(self.master, 4096))
                if not self.streaming:
                    next_t = time.monotonic()
                    continue
                if self.n_frames is not None and self.sent >= self.n_frames:
                    continue
                if time.monotonic() >= next_t:
                    pkt = self.packet(self.sent)
                    if self.corrupt is not None:
                        pkt = self.corrupt(self.sent, pkt)
                    os.write(self.master, pkt)
                    self.sent += 1
                    next_t += 1.0 / self.rate
        except OSError:
            pass  # master closed under us

    def wait_sent(self, n: int, timeout: float = 10.0) -> None:
        deadline = time.monotonic() + timeout
        while self.sent < n and time.monotonic() < deadline:
            time.sleep(0.01)
        assert self.sent >= n, f"fake sent {self.sent} of {n} frames"

    def hangup(self) -> None:
        """Stop the feeder and close both ends (the 'cable is pulled'); idempotent.

        The descriptors are forgotten once closed: a second call (``close`` after ``hangup``)
        must not close numbers the system has since handed to someone else.
        """
        self._stop.set()
        if self._thread is not threading.current_thread():
            self._thread.join(2.0)
        with self._close_lock:  # a timer's hangup and the test's close may race: one closes
            fds, self.master, self.slave = (self.master, self.slave), None, None
        for fd in fds:
            if fd is not None:
                os.close(fd)

    close = hangup

    def __enter__(self) -> FakeDevice:
        return self

    def __exit__(self, *exc: object) -> None:
        self.hangup()


# -- self-tests of the fake ------------------------------------------------------------------
def _read_all(fd: int, n: int, timeout: float = 2.0) -> bytes:
    out = b""
    deadline = time.monotonic() + timeout
    while len(out) < n and time.monotonic() < deadline:
        r, _, _ = select.select([fd], [], [], 0.05)
        if r:
            out += os.read(fd, n - len(out))
    return out


def test_fake_answers_identify_on_raw_pty() -> None:
    from psmat.protocol import V2Decoder, encode_command, parse_identify
    with FakeDevice() as fake:
        os.write(fake.slave, encode_command(Opcode.IDENTIFY))
        data = _read_all(fake.slave, 20 + len(IDENTIFY_TEXT))
        (reply,) = V2Decoder().feed(data)
        assert parse_identify(reply.text)["rows"] == 16


def test_fake_streams_paced_frames_after_start() -> None:
    from psmat.protocol import V2Decoder, encode_command
    with FakeDevice(rate=200, n_frames=5) as fake:
        time.sleep(0.05)
        assert fake.sent == 0
        os.write(fake.slave, encode_command(Opcode.START))
        data = _read_all(fake.slave, 20 + 5 * 530)
        frames = [e for e in V2Decoder().feed(data) if hasattr(e, "data")]
        assert [f.seq for f in frames] == [0, 1, 2, 3, 4]
        np.testing.assert_array_equal(frames[3].data, psm_frame(3))


def test_hangup_then_close_leaves_reused_descriptors_alone() -> None:
    fake = FakeDevice(stream_on_start=False)
    old = (fake.master, fake.slave)
    fake.hangup()
    # the system hands the freed numbers to the next opens: put a file at exactly those numbers
    spare = os.open(os.devnull, os.O_RDONLY)
    try:
        for fd in old:
            os.dup2(spare, fd)
        fake.close()                      # the same method again: must not close them
        for fd in old:
            os.fstat(fd)                  # raises OSError (EBADF) if closed under their new owner
    finally:
        for fd in {spare, *old}:
            os.close(fd)
