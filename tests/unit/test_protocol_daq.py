"""Material DAQ text lines and commands (thesis §2.4.1, docs/protocol.md)."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.protocol import (DAQ_START, DAQ_STOP, DaqLineDecoder, DaqMalformed, DaqSample, encode_daq_command,
                            encode_daq_line, parse_daq_line)

LINE = b"512,498,1023,0,77,301,290,288,1001,12\r\n"
COUNTS = [512, 498, 1023, 0, 77, 301, 290, 288, 1001, 12]


def test_encode_layout():
    assert encode_daq_line(COUNTS) == LINE
    assert encode_daq_line(np.array(COUNTS, dtype=np.uint16)) == LINE


def test_parse():
    for line in (LINE, LINE.decode(), LINE[:-2], b"512, 498,1023,0,77,301,290,288,1001,12\n"):
        out = parse_daq_line(line)
        assert out.tolist() == COUNTS and out.dtype == np.int16


def test_commands():
    assert DAQ_START == b"s" and DAQ_STOP == b"f"
    assert encode_daq_command("start") == b"s" and encode_daq_command("stop") == b"f"
    with pytest.raises(ValueError, match="start"):
        encode_daq_command("go")


@pytest.mark.parametrize("bad, msg", [
    (b"1,2,3\r\n", "3 fields"),
    (b"1,2,3,4,5,6,7,8,9,10,11\r\n", "11 fields"),
    (b"1,2,3,4,5,6,7,8,9,1024\r\n", "exceeds 1023"),
    (b"1,2,3,4,5,-6,7,8,9,10\r\n", "field 5"),
    (b"1,2,3,4,5,6,7,8,9,x\r\n", "field 9"),
    (b"1,2,3,4,5,6,7,8,9,\r\n", "field 9"),
    (b"1,2,3,4,5,6,7,8,9,1.5\r\n", "field 9"),
    (b"\xff\xfe,2,3,4,5,6,7,8,9,10\r\n", "ASCII"),
])
def test_parse_errors(bad, msg):
    with pytest.raises(ValueError, match=msg):
        parse_daq_line(bad)


def test_encode_errors():
    with pytest.raises(ValueError, match=r"shape \(10,\)"):
        encode_daq_line([1, 2, 3])
    with pytest.raises(ValueError, match=r"\[0, 1023\]"):
        encode_daq_line([1024] + [0] * 9)
    with pytest.raises(TypeError, match="integers"):
        encode_daq_line([0.5] * 10)
    with pytest.raises(TypeError):
        parse_daq_line(12)


def test_decoder_random_chunks_and_malformed(rng):
    sent = rng.integers(0, 1024, (200, 10))
    lines = [encode_daq_line(c) for c in sent]
    lines.insert(50, b"garbage\r\n")
    lines.insert(120, b"1,2,3\r\n")
    lines.insert(7, b"\r\n")                       # blank line: ignored
    stream = b"".join(lines) + b"5,5,5"            # acquisition stopped mid-line
    dec = DaqLineDecoder()
    events = []
    i = 0
    while i < len(stream):
        step = int(rng.integers(1, 30))
        events += dec.feed(stream[i:i + step])
        i += step
    events += dec.finish()
    samples = [e for e in events if isinstance(e, DaqSample)]
    bad = [e for e in events if isinstance(e, DaqMalformed)]
    np.testing.assert_array_equal(np.stack([s.counts for s in samples]), sent)
    assert [b.raw for b in bad] == [b"garbage", b"1,2,3", b"5,5,5"]
    assert dec.samples == 200 and dec.malformed == 3 and dec.blank == 1 and dec.lines == 203
    assert dec.bytes_in == len(stream)
    assert [s.line for s in samples[:3]] == [0, 1, 2]


def test_decoder_runaway_line():
    dec = DaqLineDecoder(max_line=64)
    events = dec.feed(b"x" * 100)
    assert len(events) == 1 and isinstance(events[0], DaqMalformed) and "longer" in events[0].reason
    events = dec.feed(b"\r\n" + LINE)
    assert [type(e) for e in events] == [DaqSample] and events[0].counts.tolist() == COUNTS
    with pytest.raises(TypeError, match="bytes-like"):
        dec.feed("1,2")
