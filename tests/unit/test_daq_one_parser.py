"""The material DAQ's lines have one parser: the live reader and the log loader agree.

The wire path (:func:`psmat.protocol.parse_daq_line`, :class:`psmat.protocol.DaqLineDecoder`)
and the log path (:func:`psmat.sensor.load_daq_log`) used to parse lines on their own: the
log took white space, semicolons and any float ("10.0", "1e1", "+10", "1_0"), the wire only
commas and digits. Each line below is now accepted by both with the same counts, or rejected
by both.
"""

from __future__ import annotations

import numpy as np
import pytest

from psmat.protocol import DaqLineDecoder, DaqMalformed, DaqSample, parse_daq_fields, parse_daq_line
from psmat.sensor import load_daq_log

GOOD = {
    "512,498,1023,0,77,301,290,288,1001,12": [512, 498, 1023, 0, 77, 301, 290, 288, 1001, 12],
    "1, 2 ,3,4,5,6,7,8,9,10": list(range(1, 11)),
    "1 2 3 4 5 6 7 8 9 10": list(range(1, 11)),          # white space, as logs saved by hand
    "1;2;3;4;5;6;7;8;9;10": list(range(1, 11)),          # semicolons (spreadsheet exports)
    "\t0,0,0,0,0,0,0,0,0,0 ": [0] * 10,
}
BAD = [
    "1,2,3,4,5,6,7,8,9,10.0",     # a count is digits only
    "1,2,3,4,5,6,7,8,9,1e1",
    "1,2,3,4,5,6,7,8,9,+10",
    "1,2,3,4,5,6,7,8,9,1_0",
    "1,2,3,4,5,6,7,8,9,nan",
    "1,2,3,4,5,6,7,8,9,-6",
    "1,2,3,4,5,6,7,8,9,1024",     # above the 10-bit ADC
    "1,2,3,4,5,6,7,8,9,",
    "1,,3,4,5,6,7,8,9,10",
    "1,2,3",
    "1,2,3,4,5,6,7,8,9,10,11",
    "garbage",
]


def _wire(line: str) -> list[int] | None:
    """Counts through the incremental decoder (None if it reports the line malformed)."""
    dec = DaqLineDecoder()
    events = dec.feed(line.encode("ascii") + b"\r\n")
    assert len(events) == 1
    if isinstance(events[0], DaqMalformed):
        with pytest.raises(ValueError):
            parse_daq_line(line)
        return None
    assert isinstance(events[0], DaqSample)
    np.testing.assert_array_equal(parse_daq_line(line), events[0].counts)
    return events[0].counts.tolist()


def _log(line: str) -> list[int] | None:
    """Counts through the log loader (None if it rejects the line)."""
    try:
        run = load_daq_log([line + "\n"])
    except ValueError:
        return None
    return run.meta["readings"][0].astype(int).tolist()


@pytest.mark.parametrize("line", list(GOOD))
def test_both_paths_accept_with_the_same_counts(line):
    assert _wire(line) == GOOD[line]
    assert _log(line) == GOOD[line]


@pytest.mark.parametrize("line", BAD)
def test_both_paths_reject(line):
    assert _wire(line) is None
    assert _log(line) is None


def test_fields_time_column_and_volts():
    # a time column (ms, any decimal) before the counts; readings in volts are decimals too
    np.testing.assert_array_equal(parse_daq_fields("1500.250, 3, 4", 3, counts_from=1), [1500.25, 3.0, 4.0])
    np.testing.assert_array_equal(parse_daq_fields("0 2.5 .5 1e-1", 4, counts_from=4), [0.0, 2.5, 0.5, 0.1])
    with pytest.raises(ValueError, match="field 1 is not a decimal count"):
        parse_daq_fields("1500.0, 3.5, 4", 3, counts_from=1)
    with pytest.raises(ValueError, match="field 0 is not a finite decimal number"):
        parse_daq_fields("inf 1", 2, counts_from=1)
    with pytest.raises(ValueError, match="field 1 is not a finite decimal number"):
        parse_daq_fields("1 1e999", 2, counts_from=2)
