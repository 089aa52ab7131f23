"""What a serial device's counters say went wrong (psmat.acquire.invalid_line, silence_line, link_line): the lines
psmat record prints after a recording and the lab page shows while the mat runs."""

from __future__ import annotations

from types import SimpleNamespace

import time

from psmat.acquire import invalid_line, link_line, silence_line

DIY = SimpleNamespace(bits=10, shape=(16, 16), port="/dev/ttyUSB0", protocol="csv", baudrate=115200)


def test_invalid_rows_by_reason_most_first_with_what_to_check() -> None:
    line = invalid_line({"range": 300, "count": 2, "token": 0}, DIY, rows=1000)
    assert line == ("invalid rows by reason, since the port opened: range 300: counts above 1023, the most 10 bits "
                    "hold: is the board's ADC wider (the profile's bits, --bits)?; count 2: lines of another number "
                    "of counts than 16x16: is the shape right (--shape)?")


def test_a_noisy_percent_or_one_row_per_lost_port_is_no_setting_to_check() -> None:
    """Fewer than 1 % of the rows invalid says nothing, nor one invalid row per loss of the port (the line
    being sent when it vanished is cut); without the row count every reason is said."""
    assert invalid_line({"count": 9}, DIY, rows=1000) is None and invalid_line({"count": 10}, DIY, rows=1000)
    assert invalid_line({"count": 1}, DIY) is not None and invalid_line({}, DIY) is None
    # the line cut by the port's opening is no row (CsvDecoder(opened=True)): one invalid row of 20 is said
    assert invalid_line({"count": 1}, DIY, rows=20) is not None
    assert invalid_line({"count": 1}, DIY, rows=20, losses=1) is None
    assert invalid_line({"count": 2}, DIY, rows=100, losses=1) is not None
    assert invalid_line({"count": 2}, DIY, rows=100, losses=2) is None


def test_a_silent_port_and_one_that_sends_no_frame() -> None:
    assert silence_line(0, DIY).startswith("no byte came from /dev/ttyUSB0: is the board running")
    assert silence_line(500, DIY).startswith("500 bytes came from /dev/ttyUSB0 and none formed a frame of the csv "
                                             "protocol: does the board send at 115200 baud")
    assert silence_line(0, SimpleNamespace(port="lsl:mat")) is None  # an LSL stream has no serial line


def test_a_lost_port_while_it_is_lost_and_after_it_came_back() -> None:
    """A reconnecting device: since when its port is lost (this computer's time of day) and for how long;
    after, when and for how long it was away. Nothing for a device that does not reconnect or never lost it."""
    mat = SimpleNamespace(port="/dev/ttyUSB0", reconnect=True, reconnect_max_delay_s=2.0)
    lost_at = time.mktime((2026, 11, 27, 10, 32, 15, 0, 0, -1)) + 0.4   # 10:32:15.4 on this computer's clock
    line = link_line(SimpleNamespace(lost_at=lost_at, last_gap=None, reconnects=0), mat, now=lost_at + 12.2)
    assert line == ("/dev/ttyUSB0 is lost since 10:32:15 (12 s): psmat re-opens it every 2 s at most - is the board's "
                    "USB cable plugged in and the board powered? Frames resume when it is back (a recording running "
                    "now keeps its file)")
    back = SimpleNamespace(lost_at=None, last_gap=(lost_at, 4.26), reconnects=2)
    assert link_line(back, mat) == ("/dev/ttyUSB0 was lost and found again 2 times since it opened, the last at "
                                    "10:32:15 for 4.3 s: a recording running then has no frames for that time")
    assert link_line(SimpleNamespace(lost_at=None, last_gap=None, reconnects=0), mat) is None
    once = SimpleNamespace(port="/dev/ttyUSB0", reconnect=False)  # psmat record: a lost port ends the recording
    assert link_line(SimpleNamespace(lost_at=lost_at, last_gap=None, reconnects=0), once) is None
