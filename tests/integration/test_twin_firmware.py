"""The firmware cores (C, firmware/core) as compiled into psmat._core.firmware for the twin:
their bytes are psmat.protocol's bytes, and the mux wiring is undone (docs/spec.md §5)."""

from __future__ import annotations

import numpy as np
import pytest

from psmat import protocol
from psmat._core import firmware as fw


@pytest.mark.parametrize("shape", [(16, 16), (3, 5), (1, 1), (64, 64)])
def test_psm_frames_are_psmat_protocol_frames(shape, rng):
    for proto in (1, 2):
        dev = fw.PsmFirmware(*shape, proto, "SN42")
        for k in range(3):
            counts = rng.integers(0, 4096, shape).astype(np.uint16)
            t_us = int(rng.integers(0, 2**32))
            sent = dev.tick(counts, t_us)
            expected = protocol.encode_v1(counts) if proto == 1 else protocol.encode_v2(counts, k, t_us)
            assert sent == expected


def test_mux_addresses_are_undone(rng):
    # every cell holds its own index: the decoded frame must come back in logical order
    counts = np.arange(16 * 16, dtype=np.uint16).reshape(16, 16)
    frames, valid = protocol.decode_v1(fw.PsmFirmware(16, 16, 1).tick(counts, 0), (16, 16))
    assert valid.all() and np.array_equal(frames[0], counts)


def test_commands_and_replies():
    dev = fw.PsmFirmware(16, 16, 2, "ABC123")
    reply = dev.receive(protocol.encode_command(protocol.Opcode.IDENTIFY))
    # the reply is exactly the packet psmat.protocol encodes for that text (seq 0: no frame yet)
    text = "device=psm fw=0.1.0 rows=16 cols=16 rate=100 proto=2 serial=ABC123 r_o=2200 v_ref=3.3 bits=12"
    assert reply == protocol.encode_reply(protocol.Opcode.IDENTIFY, protocol.Status.OK, text, 0, 0)
    assert protocol.parse_identify(text)["serial"] == "ABC123"
    # SET_RATE retimes the timer, out-of-range is refused with status 1
    assert dev.receive(protocol.encode_command(protocol.Opcode.SET_RATE, 165))[16:18] == bytes([3, 0])
    assert dev.rate_hz == 165
    assert dev.receive(protocol.encode_command(protocol.Opcode.SET_RATE, 5000))[16:18] == bytes([3, 1])
    assert dev.rate_hz == 165
    # STOP silences the device; START resumes
    dev.receive(protocol.encode_command(protocol.Opcode.STOP))
    assert dev.tick(np.zeros((16, 16), np.uint16), 0) == b"" and not dev.streaming
    dev.receive(protocol.encode_command(protocol.Opcode.START))
    assert len(dev.tick(np.zeros((16, 16), np.uint16), 0)) == protocol.v2_frame_size((16, 16))
    # CAL_HOLD: every cell of the frame reads the held pair
    counts = np.arange(256, dtype=np.uint16).reshape(16, 16)
    dev.receive(protocol.encode_command(protocol.Opcode.CAL_HOLD, protocol.cal_hold_arg(3, 7)))
    assert dev.hold == (3, 7)
    frames = protocol.decode_v2(dev.tick(counts, 0))["frames"]
    assert np.all(frames[0] == counts[3, 7])


def test_imu_and_daq_frames(rng):
    angles = rng.uniform(-180, 180, (5, 3)).astype(np.float32)
    assert fw.ImuFirmware(1).tick(angles, 0) == protocol.encode_imu_v1(angles)
    assert fw.ImuFirmware(2).tick(angles, 77) == protocol.encode_v2(angles, 0, 77, kind="imu")
    daq = fw.DaqFirmware()
    counts = rng.integers(0, 1024, 10).astype(np.uint16)
    assert daq.tick(counts) == b""  # idle until 's'
    daq.receive(protocol.encode_daq_command("start"))
    assert daq.tick(counts) == protocol.encode_daq_line(counts)
    daq.receive(protocol.encode_daq_command("stop"))
    assert daq.tick(counts) == b"" and not daq.running


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="rows and cols"):
        fw.PsmFirmware(0, 16)
    with pytest.raises(ValueError, match="protocol"):
        fw.PsmFirmware(16, 16, 3)
    with pytest.raises(ValueError, match=r"\(16, 16\)"):
        fw.PsmFirmware(16, 16).tick(np.zeros((4, 4), np.uint16), 0)
