"""The twin on a real pseudo-terminal (docs/spec.md §5): pacing, commands, faults, the CLI."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np
import pytest
import serial

from psmat import protocol
from psmat.twin import Faults, SerialTwin
from psmat.twin.pty_link import pty_available
from conftest import child_preexec


def _read_until(port: serial.Serial, decoder, done, timeout_s: float = 30.0) -> list:
    """Decoded events until ``done(events)``; a hang guard fails the test after ``timeout_s``."""
    events, deadline = [], time.monotonic() + timeout_s
    while not done(events):
        if time.monotonic() > deadline:
            pytest.fail(f"the twin did not deliver within {timeout_s:g} s: {len(events)} events")
        events += decoder.feed(port.read(4096))
    return events


def _frames(events: list) -> list:
    return [e for e in events if isinstance(e, protocol.Frame)]


def _n_frames(n: int):
    return lambda events: len(_frames(events)) >= n


def test_frames_arrive_in_sequence_stamped_by_the_firmware_timer():
    rate = 165
    with SerialTwin("psm", rate, "v2", scene="quiet") as twin, serial.serial_for_url(twin.port, timeout=0.05) as s:
        s.reset_input_buffer()
        dec = protocol.V2Decoder()
        frames = _frames(_read_until(s, dec, _n_frames(2 * rate)))
    seqs = np.array([f.seq for f in frames])
    assert all(f.valid for f in frames) and np.all(np.diff(seqs) == 1)
    assert dec.stats["invalid"] == 0 and dec.stats["dropped"] == 0
    # The device clock is the timer's, whatever the host's jitter: every stamp lies on the grid
    # of the frame period, 1e6/165 µs (rounded to the µs), and advances by whole periods.
    periods = np.array([f.t_us for f in frames]) * rate / 1e6
    k = np.round(periods)
    assert np.all(np.abs(periods - k) * 1e6 / rate <= 0.5)
    assert np.all(np.diff(k) >= 1)


def test_host_commands_reach_the_firmware():
    def answered(events: list) -> bool:
        return [e.opcode for e in events if isinstance(e, protocol.Reply)][-2:] == \
            [protocol.Opcode.SET_PROTOCOL, protocol.Opcode.IDENTIFY]

    with SerialTwin("psm", 100, "v1", scene="quiet") as twin, serial.serial_for_url(twin.port, timeout=0.05) as s:
        s.write(protocol.encode_command(protocol.Opcode.SET_PROTOCOL, 2))
        s.write(protocol.encode_command(protocol.Opcode.IDENTIFY))
        dec = protocol.V2Decoder()
        events = _read_until(s, dec, lambda ev: answered(ev) and any(f.valid for f in _frames(ev)))
    replies = [e for e in events if isinstance(e, protocol.Reply)]
    assert protocol.parse_identify(replies[-1].text)["proto"] == 2
    assert any(isinstance(e, protocol.Frame) and e.valid and e.seq is not None for e in events)  # streaming v2


def test_bit_flips_become_invalid_rows_not_lost_time():
    faults = Faults(bit_flip=2e-4, seed=1)
    with SerialTwin("psm", 100, "v2", scene="quiet", faults=faults) as twin, \
            serial.serial_for_url(twin.port, timeout=0.05) as s:
        s.reset_input_buffer()
        dec = protocol.V2Decoder()
        frames = _frames(_read_until(s, dec, lambda ev: dec.stats["invalid"] > 0 and _n_frames(150)(ev)))
    assert twin.stats.bits_flipped > 0 and dec.stats["invalid"] > 0
    # Every frame sent between the first and the last valid one (the only ones whose sequence
    # number is known) is accounted for: good, invalid (CRC) or dropped (a header destroyed).
    valid = [i for i, f in enumerate(frames) if f.valid]
    first, last = valid[0], valid[-1]
    assert last - first + 1 + dec.stats["dropped"] == frames[last].seq - frames[first].seq + 1
    assert all(f.data.max() < 4096 for f in frames if f.valid)


def test_a_disconnect_is_seen_by_the_host():
    # the fault counts from the twin's start: 2 s leave a loaded machine time to open the port first
    with SerialTwin("psm", 100, "v2", scene="quiet", faults=Faults(disconnect_after_s=2.0)) as twin:
        s = serial.serial_for_url(twin.port, timeout=0.05)
        t0 = time.monotonic()
        with pytest.raises(serial.SerialException):
            while time.monotonic() - t0 < 30:  # hang guard: the disconnect comes after 2 s
                s.read(4096)
        assert twin.disconnected
        assert not os.path.lexists(twin.port)  # the port went with the cable
        s.close()


@pytest.mark.parametrize("end", ["stop", "disconnect"])
def test_a_gone_twins_port_never_leads_to_a_later_twin(end: str):
    """A host still re-opening an old twin's port must not reach the next twin's pty (a former
    flake: the system reuses pty numbers at once, and two hosts on one pty break each other's stream)."""
    first = SerialTwin("psm", 100, "v2", scene="quiet").start()
    port = first.port
    getattr(first, end)()
    first.stop()
    with SerialTwin("psm", 100, "v2", scene="quiet") as second:
        assert second.port != port
        with pytest.raises(serial.SerialException):
            serial.serial_for_url(port, timeout=0.05)


@pytest.mark.skipif(not pty_available(), reason="no pseudo-terminals here (Windows): tests/integration/test_twin_tcp.py covers TCP")
def test_simulate_command_prints_the_port_first():
    with subprocess.Popen([sys.executable, "-m", "psmat", "simulate", "--rate", "100", "--protocol", "v1",
                           "--scene", "quiet", "--duration", "20"], stdout=subprocess.PIPE, text=True,
                          preexec_fn=child_preexec()) as proc:
        try:
            port = proc.stdout.readline().strip()
            assert os.path.realpath(port).startswith("/dev/")  # a terminal device
            with serial.Serial(port, timeout=0.05) as s:
                s.reset_input_buffer()
                frames = _frames(_read_until(s, protocol.V1Decoder((16, 16)), _n_frames(20)))
            assert all(f.valid for f in frames)
        finally:
            proc.terminate()
            assert proc.wait(10) == 0
    assert not os.path.lexists(port)  # the simulator took its port with it
