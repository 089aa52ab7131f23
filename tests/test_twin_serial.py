"""The twin on a real pseudo-terminal (SPEC §5): pacing, commands, faults, the CLI."""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pytest
import serial

from psmat import protocol
from psmat.twin import Faults, SerialTwin


def _read_for(port: serial.Serial, decoder, seconds: float) -> list:
    events, t0 = [], time.monotonic()
    while time.monotonic() - t0 < seconds:
        events += decoder.feed(port.read(4096))
    return events


def test_frames_arrive_at_the_rate_in_sequence():
    with SerialTwin("psm", 165, "v2", scene="quiet") as twin, serial.Serial(twin.port, timeout=0.05) as s:
        s.reset_input_buffer()
        dec = protocol.V2Decoder()
        frames = [e for e in _read_for(s, dec, 2.0) if isinstance(e, protocol.Frame)]
    seqs = np.array([f.seq for f in frames])
    assert len(frames) > 0.8 * 165 * 2 and np.all(np.diff(seqs) == 1)
    assert dec.stats["invalid"] == 0 and dec.stats["dropped"] == 0
    # the device clock advances at the frame period (1/165 s), whatever the host's jitter
    assert np.median(np.diff([f.t_us for f in frames])) == pytest.approx(1e6 / 165, rel=0.05)


def test_host_commands_reach_the_firmware():
    with SerialTwin("psm", 100, "v1", scene="quiet") as twin, serial.Serial(twin.port, timeout=0.05) as s:
        s.write(protocol.encode_command(protocol.Opcode.SET_PROTOCOL, 2))
        s.write(protocol.encode_command(protocol.Opcode.IDENTIFY))
        dec = protocol.V2Decoder()
        events = _read_for(s, dec, 0.5)
    replies = [e for e in events if isinstance(e, protocol.Reply)]
    assert [r.opcode for r in replies][-2:] == [protocol.Opcode.SET_PROTOCOL, protocol.Opcode.IDENTIFY]
    assert protocol.parse_identify(replies[-1].text)["proto"] == 2
    assert any(isinstance(e, protocol.Frame) and e.valid for e in events)  # now streaming v2


def test_bit_flips_become_invalid_rows_not_lost_time():
    faults = Faults(bit_flip=2e-4, seed=1)
    with SerialTwin("psm", 100, "v2", scene="quiet", faults=faults) as twin, \
            serial.Serial(twin.port, timeout=0.05) as s:
        s.reset_input_buffer()
        dec = protocol.V2Decoder()
        frames = [e for e in _read_for(s, dec, 1.5) if isinstance(e, protocol.Frame)]
    assert twin.stats.bits_flipped > 0 and dec.stats["invalid"] > 0
    span = frames[-1].seq - frames[0].seq + 1
    # every frame sent is accounted for: good, invalid (CRC) or dropped (a header destroyed)
    assert len(frames) + dec.stats["dropped"] == span
    assert all(f.data.max() < 4096 for f in frames if f.valid)


def test_a_disconnect_is_seen_by_the_host():
    with SerialTwin("psm", 100, "v2", scene="quiet", faults=Faults(disconnect_after_s=0.3)) as twin:
        s = serial.Serial(twin.port, timeout=0.05)
        t0 = time.monotonic()
        with pytest.raises(serial.SerialException):
            while time.monotonic() - t0 < 5:
                s.read(4096)
        assert time.monotonic() - t0 < 3  # a hang guard, not a performance claim
        assert twin.disconnected
        s.close()


def test_simulate_command_prints_the_port_first():
    with subprocess.Popen([sys.executable, "-m", "psmat", "simulate", "--rate", "100", "--protocol", "v1",
                           "--scene", "quiet", "--duration", "20"], stdout=subprocess.PIPE, text=True) as proc:
        try:
            port = proc.stdout.readline().strip()
            assert port.startswith("/dev/")
            with serial.Serial(port, timeout=0.05) as s:
                s.reset_input_buffer()
                dec = protocol.V1Decoder((16, 16))
                frames = [e for e in _read_for(s, dec, 0.6) if isinstance(e, protocol.Frame)]
            assert len(frames) > 20 and all(f.valid for f in frames)
        finally:
            proc.terminate()
            assert proc.wait(10) == 0
