"""The csv text protocol of do-it-yourself mats (docs/protocol.md "csv", docs/spec.md §5).

Byte strings are written by hand; what each must give follows from the rules of
docs/protocol.md, worked out in the comments.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from psmat.protocol import CSV_SEPARATORS, CsvDecoder, Frame, decode_csv, encode_csv

F23 = np.array([[1, 2, 3], [40, 50, 60]])   # a (2, 3) frame
LINE = b"1,2,3,40,50,60\n"                    # F23, one frame per line
BLOCK = b"1,2,3\n40,50,60\n\n"                # F23, R lines then a blank line


def run(data: bytes, shape=(2, 3), bits: int = 10, **kw) -> tuple[list[Frame], CsvDecoder]:
    dec = CsvDecoder(shape, bits, **kw)
    events = dec.feed(data)
    events += dec.finish()
    return events, dec


def flags(events: list[Frame]) -> list[bool]:
    return [e.valid for e in events]


# -- encoding ------------------------------------------------------------------------------
def test_encode_writes_both_layouts_as_the_grammar_says():
    assert encode_csv(F23) == LINE
    assert encode_csv(F23, "block") == BLOCK
    assert encode_csv(F23, "block", sep=";", marker="#", eol="\r\n") == b"1;2;3\r\n40;50;60\r\n#\r\n"
    assert encode_csv(F23, sep=", ") == b"1, 2, 3, 40, 50, 60\n"


@pytest.mark.parametrize("kwargs, words", [
    ({"layout": "grid"}, "layout"), ({"sep": "|"}, "sep"), ({"eol": "\r"}, "eol"),
    ({"layout": "block", "marker": "7 end"}, "marker"), ({"layout": "block", "marker": ""}, "marker"),
    ({"layout": "block", "marker": "-x"}, "marker"), ({"marker": "#"}, "block"),
])
def test_encode_rejects_bad_options_in_one_line(kwargs, words):
    with pytest.raises(ValueError, match=words):
        encode_csv(F23, **kwargs)


def test_encode_rejects_non_counts():
    with pytest.raises(TypeError):
        encode_csv(F23 + 0.5)
    with pytest.raises(ValueError):
        encode_csv(-F23)
    with pytest.raises(ValueError):
        encode_csv(F23.ravel())


@pytest.mark.parametrize("sep", CSV_SEPARATORS)
@pytest.mark.parametrize("layout", ["line", "block"])
def test_every_separator_and_layout_decodes_back(sep, layout):
    rng = np.random.default_rng(5)
    frames = rng.integers(0, 1024, (4, 5, 7))
    data = b"".join(encode_csv(f, layout, sep) for f in frames)
    got, valid = decode_csv(data, (5, 7), bits=10)
    assert valid.all() and got.dtype == np.uint16
    np.testing.assert_array_equal(got, frames)


# -- lines ---------------------------------------------------------------------------------
def test_a_header_line_is_skipped_not_an_invalid_row():
    header = b"r0c0,r0c1,r0c2,r1c0,r1c1,r1c2\n"
    events, dec = run(header + LINE)
    assert flags(events) == [True] and dec.invalid == 0
    assert dec.skipped == len(header) and events[0].offset == len(header)
    np.testing.assert_array_equal(events[0].data, F23)


def test_separators_mixed_runs_and_line_ends():
    # ",", ";", tab and spaces mixed, runs of them, one at both ends, CRLF: still six numbers
    events, _ = run(b" 1, 2;3\t40  ;  50 60,\r\n")
    assert flags(events) == [True]
    np.testing.assert_array_equal(events[0].data, F23)


@pytest.mark.parametrize("line, reason", [
    (b"1,2,3,40,50\n", "count"),            # five numbers: neither R*C = 6 nor C = 3 ... a line frame
    (b"1,2,3,40,50,60,7\n", "count"),
    (b"1,2,x,40,50,60\n", "token"),          # not a number
    (b"1,2,3,40,-5,60\n", "token"),          # a negative number
    (b"1,2,3,40,5.0,60\n", "token"),         # not an integer
    (b"1,2,3,40,1024,60\n", "range"),        # beyond 10 bits (2**10 - 1 = 1023)
    (b"1,2,3,40,99999999999999999999,60\n", "token"),  # 20 digits: never a count
])
def test_a_bad_line_is_one_invalid_row_and_the_stream_goes_on(line, reason):
    events, dec = run(LINE + line + LINE)
    assert flags(events) == [True, False, True]
    assert dec.reasons[reason] == 1 and dec.invalid == 1 and dec.frames == 2
    assert not events[1].data.any() and events[1].offset == len(LINE)
    assert events[2].offset == len(LINE) + len(line)


def test_the_bits_limit():
    top = b"1023,0,0,0,0,4095\n"
    assert flags(run(top, bits=10)[0]) == [False]          # 4095 > 1023
    assert flags(run(top, bits=12)[0]) == [True]
    assert flags(run(b"4096,0,0,0,0,0\n", bits=12)[0]) == [False]
    assert flags(run(b"65535,0,0,0,0,0\n", bits=16)[0]) == [True]
    assert flags(run(b"0001023,0,0,0,0,0\n", bits=10)[0]) == [True]   # leading zeros: the value counts


def test_a_line_starting_with_a_non_digit_is_text():
    # "+5" and "-5" start like numbers (a bad data line); "x5" and "#" are text: skipped
    events, dec = run(b"x5,2,3,40,50,60\n#\n-5,2,3,40,50,60\n+5,2,3,40,50,60\n")
    assert flags(events) == [False, False] and dec.reasons["token"] == 2
    assert dec.skipped == len(b"x5,2,3,40,50,60\n#\n")


def test_blank_lines_between_line_frames_are_nothing():
    events, dec = run(b"\n\r\n" + LINE + b"  \n" + LINE)
    assert flags(events) == [True, True] and dec.skipped == 1 + 2 + 3


def test_a_single_row_mat_reads_its_lines_as_frames():
    events, _ = run(b"1,2,3\n\n4,5,6\n", shape=(1, 3))
    assert flags(events) == [True, True]
    np.testing.assert_array_equal(events[1].data, [[4, 5, 6]])


# -- blocks --------------------------------------------------------------------------------
def test_a_block_closed_by_a_blank_line_or_a_marker():
    events, dec = run(BLOCK + b"1,2,3\n40,50,60\n# frame 2\n")
    assert flags(events) == [True, True] and dec.skipped == 0
    assert [e.offset for e in events] == [0, len(BLOCK)]
    for e in events:
        np.testing.assert_array_equal(e.data, F23)


def test_a_marker_with_fewer_than_r_rows_is_one_invalid_row():
    rows3 = (3, 3)
    events, dec = run(b"1,2,3\n4,5,6\n#\n1,2,3\n4,5,6\n7,8,9\n#\n", shape=rows3)
    assert flags(events) == [False, True] and dec.reasons["short_block"] == 1
    np.testing.assert_array_equal(events[1].data, [[1, 2, 3], [4, 5, 6], [7, 8, 9]])


def test_a_bad_row_invalidates_its_block_only():
    # row 2 has two numbers; row 2 of the next block is beyond 10 bits; then a good block
    data = b"1,2,3\n40,50\n\n" + b"1,2,3\n40,5000,60\n\n" + BLOCK
    events, dec = run(data)
    assert flags(events) == [False, False, True]
    assert dec.reasons["count"] == 1 and dec.reasons["range"] == 1
    assert events[1].offset == len(b"1,2,3\n40,50\n\n")


def test_rows_beyond_r_without_a_closing_line():
    # R = 2: three rows then a blank line. The third row finds a full block: that block is
    # invalid (its closing line is missing), and the third row opens a block that is invalid
    # too (rows after a missing closing line are not trusted): two invalid rows; then a good one.
    events, dec = run(b"1,2,3\n4,5,6\n7,8,9\n\n" + BLOCK)
    assert flags(events) == [False, False, True] and dec.reasons["long_block"] == 2
    assert [e.offset for e in events[:2]] == [0, 12]


def test_rows_never_closed_give_one_invalid_row_per_r_rows():
    # a 4-row mat read as 2 rows: its blocks of 4 rows never give a valid frame
    four = b"1,2,3\n4,5,6\n7,8,9\n10,11,12\n\n"
    events, dec = run(four * 3)
    assert not any(flags(events)) and len(events) == 6   # 12 rows, R = 2: six invalid rows


def test_a_line_frame_while_a_block_is_open():
    # one row of a block, then a whole frame on one line: the block is unclosed (invalid), the line is a frame
    events, dec = run(b"1,2,3\n" + LINE)
    assert flags(events) == [False, True] and dec.reasons["unclosed"] == 1


def test_a_wrong_count_after_blocks_belongs_to_a_block():
    # once the stream is in blocks, a row of 2 numbers opens a (bad) block instead of being a
    # line frame of its own: one invalid row for the block it started, not two
    events, dec = run(BLOCK + b"1,2\n40,50,60\n\n" + BLOCK)
    assert flags(events) == [True, False, True] and dec.reasons["count"] == 1


def test_finish_judges_the_last_line_and_closes_the_block():
    assert flags(run(LINE + LINE[:-1])[0]) == [True, True]        # a file without its last newline
    assert flags(run(LINE + LINE[:-3])[0]) == [True, False]       # cut inside the frame: 5 numbers
    assert flags(run(b"1,2,3\n40,50,60")[0]) == [True]            # a block ended by the end of the stream
    assert flags(run(b"1,2,3\n")[0]) == [False]


# -- a port just opened ----------------------------------------------------------------------
def test_a_port_opened_within_a_line_skips_the_cut_piece():
    # the port opened in the middle of "1,2,3,40,50,60\n": "3,40,50,60\n" (4 counts) is no row, its 11 bytes
    # are skipped; read as a whole log (opened=False) the same bytes are one invalid row (count)
    cut = LINE[4:]
    events, dec = run(cut + LINE + LINE, opened=True)
    assert flags(events) == [True, True] and dec.invalid == 0 and dec.skipped == len(cut) == 11
    assert [e.offset for e in events] == [11, 11 + len(LINE)]
    events, dec = run(cut + LINE + LINE)
    assert flags(events) == [False, True, True] and dec.reasons["count"] == 1 and dec.skipped == 0


def test_a_port_opened_within_a_block_skips_the_cut_block():
    # opened after the first row of a block: "40,50,60\n\n" closes a block of one row (short_block): skipped,
    # its row and its closing blank line, 10 bytes
    cut = BLOCK[6:]
    events, dec = run(cut + BLOCK + BLOCK, opened=True)
    assert flags(events) == [True, True] and dec.invalid == 0 and dec.skipped == len(cut) == 10
    assert [e.offset for e in events] == [10, 10 + len(BLOCK)]
    # opened within a row: "50,60\n" (2 counts, no block seen yet) is a cut line frame, skipped, and the blank
    # line after it closes no block (skipped as ever): 7 bytes, then every block
    events, dec = run(BLOCK[9:] + BLOCK + BLOCK, opened=True)
    assert flags(events) == [True, True] and dec.invalid == 0 and dec.skipped == 7


def test_a_port_opened_on_a_line_boundary_loses_nothing_and_only_the_first_frame_is_forgiven():
    events, dec = run(LINE + LINE, opened=True)
    assert flags(events) == [True, True] and dec.skipped == 0
    # a bad line later is an invalid row as ever, and so is one after a valid first frame
    events, dec = run(LINE[4:] + LINE[4:] + LINE, opened=True)
    assert flags(events) == [False, True] and dec.reasons["count"] == 1 and dec.skipped == 11
    events, dec = run(LINE + LINE[4:], opened=True)
    assert flags(events) == [True, False]


# -- bounded memory ------------------------------------------------------------------------
def test_a_line_longer_than_the_longest_legal_line_is_cut():
    dec = CsvDecoder((2, 3), 10)
    assert dec.max_line == 6 * (4 + 8)          # R*C numbers of up to 4 digits with 8 bytes of separators
    long = b"1," * 100 + b"\n"
    events, held = [], 0
    for b in long + LINE:                       # byte by byte: never more than max_line held
        events += dec.feed(bytes([b]))
        held = max(held, dec.pending)
    assert held <= dec.max_line
    assert flags(events) == [False, True] and dec.reasons["long"] == 1
    assert events[1].offset == len(long)
    # in one chunk, the same
    assert flags(run(long + LINE)[0]) == [False, True]


def test_a_long_text_line_is_skipped_and_a_long_block_row_spoils_its_block():
    banner = b"#" + b"=" * 500 + b"\n"
    events, dec = run(banner + LINE)
    assert flags(events) == [True] and dec.skipped == len(banner)
    events, _ = run(b"1,2,3\n" + b"4," * 80 + b"\n\n" + BLOCK)
    assert flags(events) == [False, True]


def test_bad_arguments_are_one_line():
    for bits in (0, 17, 10.0, True):
        with pytest.raises(ValueError, match="bits"):
            CsvDecoder((2, 3), bits)
    with pytest.raises(ValueError, match="max_line"):
        CsvDecoder((2, 3), 10, max_line=0)
    with pytest.raises(TypeError):
        CsvDecoder((2, 3)).feed("1,2,3\n")


# -- chunk boundaries ----------------------------------------------------------------------
MIXED = (b"hdr a;b;c\r\n" + LINE + b"1,2\n" + b"1;2;3;40;50;60\r\n" + BLOCK + b"1,2,3\n40,x,60\n\n"
         + b"1,2,3\n40,50,60\n#\n" + b"7,7,7\n#\n" + b"9," * 40 + b"\n" + LINE + b"1,2,3,40,50,2000\n"
         + b"1\t2\t3\n4 5 6\n7,8,9\n\n" + LINE[:-1])


def _summary(events: list[Frame], dec: CsvDecoder) -> tuple:
    return ([(e.valid, e.offset, e.data.tolist()) for e in events], dec.stats, dict(dec.reasons))


def test_feeding_byte_by_byte_gives_what_one_chunk_gives():
    whole = _summary(*run(MIXED))
    dec = CsvDecoder((2, 3), 10)
    events = [e for b in MIXED for e in dec.feed(bytes([b]))] + dec.finish()
    assert _summary(events, dec) == whole
    # and that is, by the rules: line, count, line, block, bad block, block, short block, the
    # long line (a bad row opening a block, unclosed), line, range, 3 rows of a 2-row block x2, last line
    assert flags(run(MIXED)[0]) == [True, False, True, True, False, True, False, False, True,
                                              False, False, False, True]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, len(MIXED)), max_size=30))
def test_random_splits_give_the_same_frames(cuts):
    whole = _summary(*run(MIXED))
    bounds = [0, *sorted(cuts), len(MIXED)]
    dec = CsvDecoder((2, 3), 10)
    events = [e for a, b in zip(bounds, bounds[1:]) for e in dec.feed(MIXED[a:b])] + dec.finish()
    assert _summary(events, dec) == whole
