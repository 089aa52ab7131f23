"""A do-it-yourself mat's csv text, recorded by the command line (docs/spec.md §5, docs/protocol.md "csv").

* ``psmat record PTY --protocol csv`` on a real pseudo-terminal pair: this test plays the mat,
  writing a known sequence (a header, frames in both layouts, separators mixed, malformed
  lines, a value beyond 10 bits) from a thread; the session's rows must be exactly the frames
  sent, in order, and the malformed ones invalid rows. The expected rows come from how the
  sequence was built, not from the decoder.
* ``psmat simulate --protocol csv`` serves text that :func:`psmat.acquire.open_device` reads.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import signal
import struct
import subprocess
import sys
import termios
import threading
import time
import tty
from pathlib import Path

import numpy as np
import pytest

from psmat.acquire import open_device
from psmat.io import load_session
from psmat.protocol import encode_csv

from conftest import child_preexec
from csv_twin import csv_twin
from recording_journal import GUARD_S, journalled, wait_until

R, C = 16, 16
BITS = 10

pytestmark = pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs pseudo-terminals (POSIX)")


def _line(values: np.ndarray | list, sep: str = ",", eol: str = "\n") -> bytes:
    return (sep.join(str(v) for v in np.ravel(values)) + eol).encode("ascii")


def _sequence(rng: np.random.Generator, rounds: int) -> tuple[list[bytes], list[np.ndarray | None]]:
    """Items to write (each a few lines) and the rows they must give: a frame, or None for an invalid row."""
    items: list[bytes] = [b"r0c0,r0c1,r0c2,etc (a header of non-numbers)\r\n"]
    rows: list[np.ndarray | None] = []

    def frame() -> np.ndarray:
        return rng.integers(0, 2**BITS, (R, C))

    for _ in range(rounds):
        f = frame()
        items.append(encode_csv(f))                                     # one frame per line
        rows.append(f)
        f = frame()
        items.append(_line(f, sep="; ", eol="\r\n"))                    # other separators, CRLF
        rows.append(f)
        items.append(_line(frame().ravel()[:-1]))                       # one number short
        rows.append(None)
        f = frame()
        items.append(_line(f, sep=" "))
        rows.append(f)
        bad = [str(v) for v in frame().ravel()]
        bad[17] = "1x7"                                                 # not a number
        items.append((",".join(bad) + "\n").encode())
        rows.append(None)
        over = frame()
        over[3, 4] = 2**BITS                                            # beyond 10 bits
        items.append(encode_csv(over))
        rows.append(None)
        neg = [str(v) for v in frame().ravel()]
        neg[200] = "-5"                                                 # a negative number
        items.append((",".join(neg) + "\n").encode())
        rows.append(None)
        f = frame()
        items.append(encode_csv(f, "block"))                            # R lines, a blank line
        rows.append(f)
        f = frame()
        items.append(encode_csv(f, "block", sep="\t", marker="# frame end", eol="\r\n"))
        rows.append(f)
        short_row = frame()
        text = encode_csv(short_row, "block").split(b"\n")
        text[5] = b",".join(text[5].split(b",")[:-1])                  # a block row one number short
        items.append(b"\n".join(text))
        rows.append(None)
        items.append(b"".join(_line(r) for r in frame()[:10]) + b"#\n")    # 10 rows, then a marker
        rows.append(None)
        f = frame()
        items.append(encode_csv(f))
        rows.append(f)
    return items, rows


def _queued(fd: int) -> int:
    """Bytes waiting in a terminal's input queue."""
    return struct.unpack("i", fcntl.ioctl(fd, termios.FIONREAD, b"\0\0\0\0"))[0]


@contextlib.contextmanager
def _recorder_on_a_pty(*options: str):
    """``psmat record PTY --protocol csv OPTIONS`` on a real pty pair, yielded as (process, master, slave) once
    the recorder has configured the port (pyserial flushes the input queue right after it does: the board
    writes after that); the process killed and the pty closed on the way out."""
    master, slave = os.openpty()
    tty.setraw(slave)
    attrs = termios.tcgetattr(slave)
    attrs[4] = attrs[5] = termios.B9600  # the recorder opens it at 115200 Bd: that says it is configured
    termios.tcsetattr(slave, termios.TCSANOW, attrs)
    proc = subprocess.Popen([sys.executable, "-m", "psmat", "record", os.ttyname(slave), "--protocol", "csv",
                             *options], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=child_preexec())
    try:
        wait_until(lambda: proc.poll() is not None or termios.tcgetattr(slave)[5] == termios.B115200,
              "the recorder never configured the port")
        assert proc.poll() is None, proc.communicate()
        yield proc, master, slave
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        os.close(master)
        os.close(slave)


def test_record_a_csv_mat_on_a_pty_keeps_every_frame_in_order(tmp_path: Path) -> None:
    rng = np.random.default_rng(2026)
    items, expected = _sequence(rng, rounds=3)
    out = tmp_path / "diy.h5"
    with _recorder_on_a_pty("--shape", f"{R}x{C}", "--seconds", "120", "-o", str(out)) as (proc, master, slave):
        time.sleep(0.5)

        def play() -> None:  # a modest rate, each item in two writes cut at a random byte
            for item in items:
                cut = int(rng.integers(0, len(item)))
                os.write(master, item[:cut])
                time.sleep(0.005)
                os.write(master, item[cut:])
                time.sleep(0.02)

        writer = threading.Thread(target=play, daemon=True)
        writer.start()
        writer.join(GUARD_S)
        assert not writer.is_alive(), "writing to the pty hung"
        wait_until(lambda: _queued(slave) == 0 or proc.poll() is not None, "the recorder stopped reading")
        # every frame decoded and journalled (the recorder still running), then stopped
        wait_until(lambda: proc.poll() is not None or journalled(out) >= len(expected),
              f"the journal never held the {len(expected)} frames written")
        proc.send_signal(signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=GUARD_S)
    assert proc.returncode == 0, stderr
    s = load_session(out)
    assert s.complete and s.counts.shape == (len(expected), R, C), (s.counts.shape, len(expected), stderr)
    assert s.valid.tolist() == [e is not None for e in expected]
    for k, e in enumerate(expected):
        if e is not None:
            np.testing.assert_array_equal(s.counts[k], e, err_msg=f"row {k}")
    assert s.device["proto"] == "csv" and s.device["bits"] == BITS and "serial" in s.device["unknown"]
    n_invalid = sum(e is None for e in expected)
    assert f"{len(expected)} frames recorded, {n_invalid} invalid, losses on the wire unknown" in stdout


def test_simulate_serves_csv_that_open_device_reads(tmp_path: Path) -> None:
    proc = subprocess.Popen([sys.executable, "-m", "psmat", "simulate", "--protocol", "csv", "--scene", "quiet",
                             "--rate", "50", "--shape", "8x12"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=child_preexec())
    try:
        port = proc.stdout.readline().strip()
        assert port, proc.communicate()
        with open_device(port, "psm", protocol="csv", shape=(8, 12), bits=BITS) as dev:
            batch = dev.read(40, timeout_s=GUARD_S)
            stats = dev.stats
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=GUARD_S)
    assert len(batch) == 40
    # the host opened the pty mid-stream: the line cut by that is skipped bytes, no row; every frame is valid
    assert batch.valid.all() and stats.invalid == 0
    assert batch.frames.shape == (40, 8, 12) and int(batch.frames[batch.valid].max()) <= 2**BITS - 1
    # the quiet scene: two feet on an 8x12 mat load some cells, the rest read the unloaded level
    assert len(np.unique(batch.frames[batch.valid])) > 10


def test_a_12_bit_board_recorded_as_10_bits_is_told_why_its_frames_are_invalid(tmp_path: Path) -> None:
    """A csv mat on a 12-bit board recorded without --bits (the csv default, 10 bits): before, the
    summary said only "N invalid". Now the reasons say what to check, and with --bits 12 none is
    out of range."""
    runs = {}
    with csv_twin("--profile", "psm16") as port:
        for bits in ([], ["--bits", "12"]):
            done = subprocess.run([sys.executable, "-m", "psmat", "record", port, "--protocol", "csv", "--shape",
                                   "16x16", *bits, "--seconds", "2", "-o", str(tmp_path / f"b{len(bits)}.h5")],
                                  capture_output=True, text=True, timeout=GUARD_S)
            assert done.returncode == 0, done.stderr
            runs[bool(bits)] = done.stdout
    why = [ln for ln in runs[False].splitlines() if ln.startswith("  invalid rows by reason")]
    assert len(why) == 1 and ": range " in why[0]
    assert why[0].split(": range ")[1].split(":")[0].isdigit()
    assert "counts above 1023, the most 10 bits hold: is the board's ADC wider (the profile's bits, --bits)?" in why[0]
    assert "range" not in runs[True] and "invalid rows" not in runs[True]
    s10, s12 = load_session(tmp_path / "b0.h5"), load_session(tmp_path / "b2.h5")
    assert not s10.valid.any() and s12.valid.all()  # (a line cut by the port's opening: skipped, no row)


@pytest.mark.parametrize("noise", [False, True])
def test_a_board_that_sends_no_frame_is_told_what_to_check(noise: bool, tmp_path: Path) -> None:
    """A do-it-yourself mat that sends nothing (its sketch not uploaded, another port), or bytes that
    form no line of counts (a board at another baud rate: what a UART reads then has no digits and
    no line ends where the text had them). Before, "0 frames recorded, 0 invalid" and nothing else.
    A real pty plays the board; the bytes written are noise without a digit."""
    from psmat.profile import load_profile

    written = 0
    options = ("--shape", f"{R}x{C}", "--seconds", "3", "-o", str(tmp_path / "none.h5"))
    with _recorder_on_a_pty(*options) as (proc, master, slave):
        port = os.ttyname(slave)
        rng = np.random.default_rng(5)
        alphabet = np.array([b for b in range(256) if not (0x30 <= b <= 0x39)], np.uint8)  # no digit
        while noise and proc.poll() is None:
            if _queued(slave) < 4096:
                written += os.write(master, rng.choice(alphabet, 300).tobytes())
            time.sleep(0.02)
        stdout, stderr = proc.communicate(timeout=GUARD_S)
    assert proc.returncode == 0, stderr
    assert "0 frames recorded, 0 invalid" in stdout
    told = [ln.strip() for ln in stdout.splitlines() if ln.startswith("  ")]
    if not noise:
        assert told == [f"no byte came from {port}: is the board running and sending (a do-it-yourself mat: its "
                        "sketch uploaded, Serial.begin called), and is this its port?"]
        return
    baud = load_profile("arduino16").baudrate
    assert len(told) == 1 and told[0].endswith(
        f" bytes came from {port} and none formed a frame of the csv protocol: does the board send at {baud} baud "
        "(its Serial.begin rate; a profile's baudrate), and speak --protocol csv?")
    assert 0 < int(told[0].split()[0]) <= written


def test_a_10_bit_board_recorded_as_12_bits_is_told_its_adc_is_narrower(tmp_path: Path) -> None:
    """An Arduino Uno's 10-bit ADC recorded under 12 bits: its counts fit (no invalid row), but an empty
    cell, 1023, reads as a loaded one, and the whole mat looked pressed with nothing said. Now the
    recording and psmat info say so; recorded with its own 10 bits, nothing is said."""
    runs = {}
    with csv_twin() as port:
        for bits in ("12", "10"):
            done = subprocess.run([sys.executable, "-m", "psmat", "record", port, "--protocol", "csv", "--shape",
                                   "16x16", "--bits", bits, "--seconds", "2", "-o", str(tmp_path / f"b{bits}.h5")],
                                  capture_output=True, text=True, timeout=GUARD_S)
            assert done.returncode == 0, done.stderr
            runs[bits] = done.stdout
    s12 = load_session(tmp_path / "b12.h5")
    top = int(s12.counts[s12.valid].max())
    # every frame valid: the line the board was sending when the port opened, cut, is skipped (no row), also
    # when its tail comes after the recording began (a loaded machine)
    assert 0 < top <= 1023 and s12.valid.all()
    told = [ln.strip() for ln in runs["12"].splitlines() if ln.startswith("  no count above")]
    # an open cell: V_ref through R_o (2200 ohm) into the ADC's input resistance (the arduino16 profile's 1e8 ohm)
    empty = round(4095 * 1e8 / (1e8 + 2200))
    assert told == [f"no count above {top} in {int(s12.valid.sum())} valid frames, where an empty cell reads {empty} of 4095 "
                    "(12 bits): is the board's ADC 10-bit? Every cell then reads as loaded: record with --bits 10 "
                    "(or a profile with bits = 10)"]
    assert "no count above" not in runs["10"]
    info = subprocess.run([sys.executable, "-m", "psmat", "info", str(tmp_path / "b12.h5")], capture_output=True,
                          text=True, timeout=GUARD_S)
    assert info.returncode == 0 and f"psmat info: {told[0]}" in info.stderr
