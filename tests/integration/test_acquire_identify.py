"""IDENTIFY at open on a real pseudo-terminal: bounded retries, unknown fields said so."""

from __future__ import annotations

import time

import pytest

from psmat.acquire import open_device
from psmat.acquire import IDENTIFY_FIELDS
from psmat.protocol import Opcode, V2Decoder, encode_command, parse_identify
from test_acquire_fake import IDENTIFY_TEXT, FakeDevice

FULL = {"device": "psm", "fw": "0.1.0", "rows": 16, "cols": 16, "rate": 165, "proto": 2, "serial": "0000A1B2",
        "r_o": 2200.0, "v_ref": 3.3, "bits": 12}


def _identifies(fake: FakeDevice) -> int:
    return sum(op == Opcode.IDENTIFY for op, _ in fake.commands)


def _wait_until(condition, timeout: float = 30.0) -> None:
    """Poll ``condition()`` until true (a hang guard, not a timing claim)."""
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.01)


def test_identify_is_retried_when_the_link_stalls_at_open() -> None:
    # the first IDENTIFY is lost on the way in; the second is answered
    with FakeDevice(lose_commands=1, stream_on_start=True) as fake, \
            open_device(fake.port, identify_timeout_s=0.3) as dev:
        assert dev.description == FULL and dev.identified
        assert fake.lost == 1


def test_a_silent_device_is_asked_a_bounded_number_of_times_and_said_unknown() -> None:
    with FakeDevice(identify=None, stream_on_start=False) as fake:
        dev = open_device(fake.port, identify_timeout_s=0.1, identify_attempts=4)
        try:
            _wait_until(lambda: _identifies(fake) >= 4)          # the fake logs every command it reads
            assert _identifies(fake) == 4
            assert not dev.identified
            assert dev.description["unknown"] == list(IDENTIFY_FIELDS["psm"])
            assert dev.description["note"] == "no reply to IDENTIFY after 4 attempts of 0.1 s"
            assert "IDENTIFY" in dev.stats.last_error
        finally:
            dev.close()


def test_identify_fields_are_the_firmwares() -> None:
    # what the firmware cores (firmware/core, compiled into psmat._core) answer to IDENTIFY
    from psmat._core import firmware as fw

    for kind, core in (("psm", fw.PsmFirmware(16, 16, 2, "0000A1B2")), ("imu", fw.ImuFirmware(2, "0000A1B2"))):
        (reply,) = V2Decoder().feed(core.receive(encode_command(Opcode.IDENTIFY), 0))
        assert tuple(parse_identify(reply.text)) == IDENTIFY_FIELDS[kind]
    assert tuple(parse_identify(IDENTIFY_TEXT)) == IDENTIFY_FIELDS["psm"]      # the fake's copy agrees


def test_fields_a_reply_leaves_out_are_unknown() -> None:
    text = "device=imu fw=0.1.0 sensors=5 rate=10"                 # no proto, serial, units
    with FakeDevice(kind="imu", identify=text, stream_on_start=True) as fake, \
            open_device(fake.port, kind="imu") as dev:
        assert dev.identified
        d = dev.description
        assert (d["device"], d["fw"], d["sensors"], d["rate"]) == ("imu", "0.1.0", "5", 10)
        assert d["unknown"] == ["proto", "serial", "units"]
        assert d["note"] == "IDENTIFY did not report proto, serial, units"


def test_a_rate_set_later_is_no_longer_unknown() -> None:
    # all three IDENTIFYs are lost, then the link recovers and SET_RATE is answered
    with FakeDevice(lose_commands=3, stream_on_start=False) as fake:
        dev = open_device(fake.port, identify_timeout_s=0.1)
        try:
            assert "rate" in dev.description["unknown"]
            dev.set_rate(200)
            assert dev.description["rate"] == 200
            assert "rate" not in dev.description["unknown"] and "fw" in dev.description["unknown"]
        finally:
            dev.close()


def test_identify_attempts_are_checked() -> None:
    with pytest.raises(ValueError, match="identify_attempts must be >= 1"):
        open_device("loop://", identify_attempts=0)
